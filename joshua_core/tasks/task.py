"""Building a task: terms looked up by name, parameters checked and model names resolved, once.

`build_task` turns a `TaskSpec` (or a registered task's name) and a compiled model into a `Task`.
Every check happens here, with errors that name the task and the term: unknown terms (with close
matches), unknown or missing parameters, parameters of the wrong type, model names that do not
exist, and terms whose output has the wrong shape (each term is evaluated once on a probe state).
The `Task` then only evaluates: its methods are pure functions of a `TermContext`, the same on
numpy and inside `jax.jit`.
"""

from __future__ import annotations

import inspect
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from numbers import Real
from typing import TYPE_CHECKING, Any

import numpy as np

from joshua_core.errors import ConfigError, PluginLoadError, UsageError
from joshua_core.kinds import Kind
from joshua_core.tasks.actuation import action_mapping, initial_state, keyframe_id
from joshua_core.tasks.cameras import resolve_cameras
from joshua_core.tasks.context import STATE_FIELDS, NumpyRandom, TermContext
from joshua_core.tasks.handles import HANDLE_TYPES, resolve_handle
from joshua_core.tasks.randomization import (
    ObservationTerms,
    Range,
    action_delay,
    default_params,
    tiled,
    with_observation_columns,
)
from joshua_core.tasks.spec import TaskSpec, TermKind, TermSpec, with_config

if TYPE_CHECKING:
    from joshua_core.plugins import PluginHost

_PROBE_ENVS = 2


@dataclass(frozen=True)
class BoundTerm:
    """A term of a built task: the function with its checked, resolved parameters."""

    name: str
    kind: TermKind
    function: Callable[..., Any]
    weight: float
    params: Mapping[str, Any]
    mode: str = ""  # events: "reset" or "interval"
    interval: int = 0  # interval events: steps between runs

    def __call__(self, ctx: TermContext) -> Any:
        return self.function(ctx, **self.params)


class Task:
    """A built task: evaluates observations, rewards, terminations, metrics and resets of N environments.

    Backends step the physics and build a `TermContext` with the fields in `fields`; everything
    else here is array code in `ctx.xp`.
    """

    def __init__(self, spec: TaskSpec, model: Any, terms: dict[TermKind, tuple[BoundTerm, ...]]) -> None:
        self.spec = spec
        self.name = spec.name
        self.frame_skip = spec.frame_skip
        self.episode_length = spec.episode_length
        self.dt = float(model.opt.timestep) * spec.frame_skip
        self.observation_terms = terms[TermKind.OBSERVATION]
        self.reward_terms = terms[TermKind.REWARD]
        self.termination_terms = terms[TermKind.TERMINATION]
        self.reset_terms = terms[TermKind.RESET]
        self.metric_terms = terms[TermKind.METRIC]
        self.reset_events = tuple(term for term in terms[TermKind.EVENT] if term.mode == "reset")
        self.interval_events = tuple(term for term in terms[TermKind.EVENT] if term.mode == "interval")
        self.curriculum = spec.curriculum  # how training environments ease the events in (None: full strength)
        self.cameras = resolve_cameras(spec.name, spec.cameras, model)  # image observations, checked against the model
        delays = [term.params["range"].high for term in terms[TermKind.EVENT] if term.function is action_delay]
        self.max_action_delay = int(max(delays, default=0))
        self.commands = dict(spec.commands)
        self.keyframe_id = keyframe_id(spec, model)
        self.action_size = int(model.nu)
        self.initial_qpos, self.initial_qvel, self.initial_ctrl = initial_state(model, self.keyframe_id)
        self.ctrl_low, self.ctrl_high, self.ctrl_offset, self.ctrl_scale = action_mapping(
            spec, model, self.initial_ctrl
        )
        self.observation_layout: tuple[tuple[str, int], ...] = ()  # (name, width) of each observation term, in order
        self.fields: frozenset[str] = frozenset()
        self.defaults: dict[str, np.ndarray] = {}  # every randomizable quantity's model value
        self.param_fields: tuple[str, ...] = ()  # those the events randomize: backends keep them per env
        self.interval_fields: frozenset[str] = frozenset()  # those the interval events randomize

    @property
    def observation_size(self) -> int:
        """Entries of the observation: the widths of its terms together."""
        return sum(width for _, width in self.observation_layout)

    # --- evaluation (pure functions of the context) ---

    def observe(self, ctx: TermContext, noise: bool = True) -> Any:
        """The observation, (N, observation_size): every observation term flattened and concatenated, plus
        the observation noise the task's events drew (`noise`=False: without it, as a value network may see)."""
        parts = [term(ctx).reshape(ctx.num_envs, -1) for term in self.observation_terms]
        observation = ctx.xp.concatenate(parts, axis=1)
        return observation + ctx.params["obs_noise"] if noise and self.noisy_observations else observation

    @property
    def noisy_observations(self) -> bool:
        """Whether an event (observation_noise) adds noise to the observations."""
        return "obs_noise" in self.param_fields

    def rewards(self, ctx: TermContext) -> tuple[Any, dict[str, Any]]:
        """The total reward (N,) and each reward term's weighted value by name."""
        weighted = {term.name: term.weight * term(ctx) for term in self.reward_terms}
        total = sum(weighted.values()) if weighted else ctx.xp.zeros(ctx.num_envs)
        return total, weighted

    def terminated(self, ctx: TermContext) -> Any:
        """(N,) bool: whether any termination term fired."""
        done = ctx.xp.zeros(ctx.num_envs, dtype=bool)
        for term in self.termination_terms:
            done = done | term(ctx).astype(bool)
        return done

    def metrics(self, ctx: TermContext) -> dict[str, Any]:
        """Each metric term's (N,) value by name."""
        return {term.name: term(ctx) for term in self.metric_terms}

    def reset(self, ctx: TermContext) -> TermContext:
        """Apply the reset terms in order to a context holding the initial state; return the randomised one.

        `ctx` needs qpos and qvel (usually `initial_qpos`/`initial_qvel` per env), `commands` (any
        values of the right shapes) and `random`.
        """
        for term in self.reset_terms:
            ctx = term(ctx)
        return ctx

    @property
    def delta_actions(self) -> bool:
        """Whether an action moves the controls in force ("delta") rather than setting them."""
        return self.spec.action.mode == "delta"

    def action_to_ctrl(self, xp: Any, action: Any, params: Mapping[str, Any] | None = None, ctrl: Any = None) -> Any:
        """Actuator controls for actions, (N, nu): clipped to [-1, 1], mapped (see ActionSpec), clipped to
        ctrlrange. "delta" adds to `ctrl`, the controls in force (N, nu); the other modes add each
        environment's randomized `ctrl_offset` where `params` has one (delta actions meet it at reset:
        `reset_ctrl`)."""
        step = self.ctrl_scale * xp.clip(action, -1.0, 1.0)
        if self.delta_actions:
            if ctrl is None:
                raise ValueError(f"task '{self.name}' has delta actions: action_to_ctrl needs the controls in force")
            return xp.clip(ctrl + step, self.ctrl_low, self.ctrl_high)
        target = self.ctrl_offset + step
        if params is not None and "ctrl_offset" in params:
            target = target + params["ctrl_offset"]
        return xp.clip(target, self.ctrl_low, self.ctrl_high)

    def action_for_ctrl(self, xp: Any, target: Any, params: Mapping[str, Any] | None = None, ctrl: Any = None) -> Any:
        """The actions (N, nu) whose controls come nearest `target` (N, nu) in one step: `action_to_ctrl`
        inverted and clipped to [-1, 1], so a target beyond one step's reach is approached at full speed. "delta"
        steps from `ctrl`, the controls in force; the other modes from the offset (with `params`' randomized one)."""
        if self.delta_actions:
            if ctrl is None:
                raise ValueError(f"task '{self.name}' has delta actions: action_for_ctrl needs the controls in force")
            base = ctrl
        else:
            base = self.ctrl_offset + (params["ctrl_offset"] if params is not None and "ctrl_offset" in params else 0.0)
        return xp.clip((target - base) / self.ctrl_scale, -1.0, 1.0)

    def reset_ctrl(self, xp: Any, num_envs: int, params: Mapping[str, Any] | None = None) -> Any:
        """The controls an episode starts with, (N, nu): the initial ctrl, where zero offsets are drawn
        (`ctrl_offset`) shifted by them, clipped to ctrlrange (what a zero action commands in "offset" mode)."""
        ctrl = xp.broadcast_to(xp.asarray(self.initial_ctrl), (num_envs, self.action_size))
        if params is not None and "ctrl_offset" in params:
            ctrl = ctrl + params["ctrl_offset"]
        return xp.clip(ctrl, self.ctrl_low, self.ctrl_high)

    def reset_context(self, xp: Any, num_envs: int, random: Any) -> TermContext:
        """A context with `num_envs` copies of the initial state and zero commands, ready for `reset`."""
        return TermContext(
            xp=xp,
            dt=self.dt,
            qpos=xp.asarray(np.tile(self.initial_qpos, (num_envs, 1))),
            qvel=xp.asarray(np.tile(self.initial_qvel, (num_envs, 1))),
            commands={name: xp.zeros((num_envs, size)) for name, size in self.commands.items()},
            random=random,
        )


def load_task_spec(name: str, plugins: PluginHost) -> TaskSpec:
    """The TaskSpec registered as `name` (a TaskSpec, or a function with no arguments returning one)."""
    component = plugins.component(Kind.TASK, name)
    target = component.load()
    spec = target() if callable(target) and not isinstance(target, TaskSpec) else target
    if not isinstance(spec, TaskSpec):
        raise PluginLoadError(
            f"task '{name}' from plugin '{component.plugin.name}' ({component.plugin.distribution}) is {spec!r}, "
            "not a joshua_core.tasks.TaskSpec"
        )
    return spec


def build_task(task: TaskSpec | str, model: Any, plugins: PluginHost, config: Any = None) -> Task:
    """Build a task for a compiled model (mujoco.MjModel); `config` is an optional `joshua.TaskConfig`.

    Raises ConfigError naming the task and term for any bad term, parameter or model name.
    """
    spec = load_task_spec(task, plugins) if isinstance(task, str) else task
    if config is not None:
        spec = with_config(spec, config)
    if spec.frame_skip < 1 or spec.episode_length < 1:
        raise ConfigError(f"task '{spec.name}': frame_skip and episode_length must be at least 1")
    terms = {
        kind: tuple(_bind(spec, kind, term, model, plugins) for term in spec.terms(kind) if term.weight != 0)
        for kind in TermKind
    }
    built = Task(spec, model, terms)
    layout, built.fields = _probe(built, model)
    built.observation_layout = tuple(layout)
    built.reset_events, built.interval_events = (
        tuple(with_observation_columns(built.name, event, layout) for event in events)
        for events in (built.reset_events, built.interval_events)
    )
    built.defaults = default_params(model, built.observation_size)
    built.param_fields, built.interval_fields = _probe_events(built)
    return built


def _bind(spec: TaskSpec, kind: TermKind, term: TermSpec, model: Any, plugins: PluginHost) -> BoundTerm:
    where = f"task '{spec.name}': {kind.value} term '{term.key}'"
    try:
        function = plugins.component(Kind.TERM, term.term).load()
    except UsageError as error:
        raise ConfigError(f"{where}: {error}") from None
    if not callable(function):
        raise PluginLoadError(f"{where}: the registered term '{term.term}' is {function!r}, not a function")
    params = _check_params(where, term, function, model)
    return BoundTerm(
        term.key, kind, function, float(term.weight), params, getattr(term, "mode", ""), getattr(term, "interval", 0)
    )


def _check_params(where: str, term: TermSpec, function: Callable[..., Any], model: Any) -> dict[str, Any]:
    """The term's parameters: given ones checked against the signature, defaults added, model names resolved."""
    parameters = list(inspect.signature(function).parameters.values())[1:]  # the first is ctx
    accepted = {p.name: p for p in parameters if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
    listing = ", ".join(accepted) or "none"
    unknown = sorted(set(term.params) - set(accepted))
    if unknown:
        raise ConfigError(
            f"{where} ({term.term}) has no parameter {', '.join(map(repr, unknown))}; its parameters: {listing}"
        )
    hints = _type_hints(function)
    resolved: dict[str, Any] = {}
    for name, parameter in accepted.items():
        if name in term.params:
            value = term.params[name]
        elif parameter.default is not parameter.empty:
            value = parameter.default
        else:
            raise ConfigError(f"{where} ({term.term}) needs parameter '{name}'; its parameters: {listing}")
        resolved[name] = _coerce(f"{where}, parameter '{name}'", value, parameter.default, hints.get(name), model)
    return resolved


def _type_hints(function: Callable[..., Any]) -> dict[str, Any]:
    try:
        return typing.get_type_hints(function)
    except Exception:  # unresolvable annotations (e.g. names only imported for type checking): use none
        return {}


def _coerce(where: str, value: Any, default: Any, hint: Any, model: Any) -> Any:
    """Resolve model names for handle parameters and check a value against its default's type."""
    if hint in (Range, ObservationTerms):
        try:
            return hint.parse(value)
        except ValueError as error:
            raise ConfigError(f"{where}: {error}") from None
    if hint in HANDLE_TYPES:
        try:
            return resolve_handle(model, hint, value)
        except ValueError as error:
            raise ConfigError(f"{where}: {error}") from None
    if isinstance(value, list):
        value = tuple(value)
    if default is inspect.Parameter.empty or default is None:
        return value
    if isinstance(default, bool) or isinstance(value, bool):
        if not isinstance(value, bool) or not isinstance(default, bool):
            raise ConfigError(f"{where}: expected {type(default).__name__}, got {value!r}")
        return value
    if isinstance(default, Real):
        if not isinstance(value, Real):
            raise ConfigError(f"{where}: expected a number, got {value!r}")
        return float(value) if isinstance(default, float) else value
    if isinstance(default, tuple) and not isinstance(value, tuple):
        raise ConfigError(f"{where}: expected a list like {list(default)}, got {value!r}")
    if isinstance(default, str) and not isinstance(value, str):
        raise ConfigError(f"{where}: expected a name, got {value!r}")
    return value


def _probe(task: Task, model: Any) -> tuple[list[tuple[str, int]], frozenset[str]]:
    """Evaluate every term once on a neutral state: check output shapes, measure the observation's layout
    ((name, width) of each observation term, in order), and record which state fields the terms read
    (backends then compute only those)."""
    read: set[str] = set()

    class ProbeContext(TermContext):
        def __getattribute__(self, name: str) -> Any:
            if name in STATE_FIELDS:
                read.add(name)
            return object.__getattribute__(self, name)

    n = _PROBE_ENVS
    identity = np.tile([1.0, 0.0, 0.0, 0.0], (n, model.nbody, 1))
    ctx = ProbeContext(
        xp=np,
        dt=task.dt,
        qpos=np.tile(task.initial_qpos, (n, 1)),
        qvel=np.zeros((n, model.nv)),
        prev_qpos=np.tile(task.initial_qpos, (n, 1)),
        xpos=np.zeros((n, model.nbody, 3)),
        xquat=identity,
        site_xpos=np.zeros((n, model.nsite, 3)),
        sensordata=np.zeros((n, model.nsensordata)),
        cfrc_ext=np.zeros((n, model.nbody, 6)),
        ctrl=np.tile(task.initial_ctrl, (n, 1)),
        action=np.zeros((n, model.nu)),
        prev_action=np.zeros((n, model.nu)),
        episode_step=np.zeros(n, dtype=np.int64),
        commands={name: np.zeros((n, size)) for name, size in task.commands.items()},
        random=NumpyRandom(np.random.default_rng(0)),
    )
    layout: list[tuple[str, int]] = []
    with np.errstate(all="ignore"):
        for term in task.observation_terms:
            value = _evaluate(task, term, ctx)
            if value.ndim < 1 or value.shape[0] != n:
                raise ConfigError(_shape_message(task, term, value, "(N,) or (N, k)"))
            layout.append((term.name, int(np.prod(value.shape[1:], dtype=np.int64))))
        for term in task.reward_terms + task.termination_terms + task.metric_terms:
            value = _evaluate(task, term, ctx)
            if value.shape != (n,):
                raise ConfigError(_shape_message(task, term, value, "(N,)"))
        reset_ctx = ctx
        for term in task.reset_terms:
            reset_ctx = _evaluate(task, term, reset_ctx)
            if not isinstance(reset_ctx, TermContext):
                raise ConfigError(
                    f"task '{task.name}': reset term '{term.name}' returned {type(reset_ctx).__name__}; "
                    "a reset term returns the context with its changes, e.g. ctx.replace(qpos=...)"
                )
            for name in ("qpos", "qvel"):
                if np.shape(getattr(reset_ctx, name)) != np.shape(getattr(ctx, name)):
                    raise ConfigError(f"task '{task.name}': reset term '{term.name}' changed the shape of {name}")
    return layout, frozenset(read)


def _probe_events(task: Task) -> tuple[tuple[str, ...], frozenset[str]]:
    """Evaluate every event once on the defaults: check it returns a context with params of unchanged shapes,
    and record which quantities the events write (backends keep only those per environment), and of those
    which the interval events write."""
    n = _PROBE_ENVS
    before = tiled(np, task.defaults, n)
    ctx = TermContext(
        xp=np,
        dt=task.dt,
        qpos=np.tile(task.initial_qpos, (n, 1)),
        qvel=np.zeros((n, len(task.initial_qvel))),
        episode_step=np.zeros(n, dtype=np.int64),
        random=NumpyRandom(np.random.default_rng(0)),
        params=before,
        defaults=task.defaults,
    )
    written: set[str] = set()
    interval: set[str] = set()
    for term in task.reset_events + task.interval_events:
        result = _evaluate(task, term, ctx)
        if not isinstance(result, TermContext) or set(result.params) != set(before):
            raise ConfigError(
                f"task '{task.name}': event '{term.name}' must return the context with its changes, "
                "e.g. ctx.replace(params={**ctx.params, name: value})"
            )
        for name, value in result.params.items():
            if np.shape(value) != np.shape(before[name]):
                raise ConfigError(f"task '{task.name}': event '{term.name}' changed the shape of params['{name}']")
            if value is not before[name]:
                written.add(name)
                if term.mode == "interval":
                    interval.add(name)
    return tuple(name for name in before if name in written), frozenset(interval)


def _evaluate(task: Task, term: BoundTerm, ctx: TermContext) -> Any:
    try:
        value = term(ctx)
    except Exception as error:  # a term can fail in any way on bad parameters; name it
        raise ConfigError(
            f"task '{task.name}': {term.kind.value} term '{term.name}' ({term.function.__name__}) failed: "
            f"{type(error).__name__}: {error}"
        ) from error
    return value if isinstance(value, TermContext) else np.asarray(value)


def _shape_message(task: Task, term: BoundTerm, value: Any, expected: str) -> str:
    return (
        f"task '{task.name}': {term.kind.value} term '{term.name}' ({term.function.__name__}) returned shape "
        f"{np.shape(value)}; expected {expected} with N = number of environments"
    )
