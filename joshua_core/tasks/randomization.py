"""Domain randomization: event terms that draw per-environment physics and control parameters.

An event term is a pure function `event(ctx, **params) -> TermContext`, like a reset term, that
writes `ctx.params`: each environment's current values of the randomizable quantities below,
(N, ...) by name. It draws around `ctx.defaults` (the model's own values), never around the current
ones, so that repeated draws do not drift. A task runs its events when an episode starts (mode
"reset") or every N steps of an episode (mode "interval"); the backends (joshua-mujoco's batch,
joshua-mjx) then simulate each environment with its values:

- model fields, written into each simulation's model: `geom_friction` (ngeom, 3), `body_mass`
  (nbody,), `body_inertia` (nbody, 3), `actuator_gainprm` / `actuator_biasprm` (nu, 10),
  `dof_damping`, `dof_armature` (nv,). Backends recompute what MuJoCo derives from them
  (mj_setConst: the inverse weights of bodies and dofs).
- appearance, model fields that only rendering reads: `geom_rgba` (ngeom, 4), the colour each geom
  shows (its material's where it has one and no colour of its own, the rule of MuJoCo's renderers),
  `cam_pos` (ncam, 3), `cam_quat` (ncam, 4), `light_pos`, `light_dir`, `light_diffuse` (nlight, 3).
- control fields: `ctrl_offset` (nu,) added to the actuator targets, `action_delay` () in control
  steps, `obs_noise` (observation size,) added to the observation, `xfrc_applied` (nbody, 6),
  an external force and torque applied for one control step (then cleared).

Ranges are `[low, high]` with a distribution ("uniform", or "log_uniform" for positive ranges) and
an operation on the default ("scale": default x sample, "add": default + sample, "set": sample).
Bad ranges and names fail when the task is built. docs/tasks.md#domain-randomization lists the terms.

A `Curriculum` eases the events in during training: each environment draws at its own strength
`ctx.strength` in [0, 1], a fraction of the way from the model's own value (no noise, no push, no
delay) to the full draw, and its strength rises after episodes that succeed and falls after ones
that fail. Without one (`ctx.strength` None, as in evaluation) every draw is at full strength.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from joshua_core.errors import ConfigError
from joshua_core.tasks.context import TermContext, set_columns
from joshua_core.tasks.handles import Actuators, Bodies, Body, Geoms, Joints, Lights, SceneCameras

MODEL_FIELDS = (
    "geom_friction",
    "body_mass",
    "body_inertia",
    "actuator_gainprm",
    "actuator_biasprm",
    "dof_damping",
    "dof_armature",
    "geom_rgba",
    "cam_pos",
    "cam_quat",
    "light_pos",
    "light_dir",
    "light_diffuse",
)
# Model fields whose change makes mj_setConst's derived quantities (inverse weights) stale.
INERTIAL_FIELDS = frozenset({"body_mass", "body_inertia", "dof_armature"})
DISTRIBUTIONS = ("uniform", "log_uniform")
OPERATIONS = ("scale", "add", "set")


@dataclass(frozen=True)
class Range:
    """A closed interval [low, high] of finite numbers, given in configs as a two-element list."""

    low: float
    high: float

    @classmethod
    def parse(cls, value: Any) -> Range:
        """The Range of `[low, high]`; ValueError for another shape, non-finite values or low > high."""
        if isinstance(value, Range):
            return value
        if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != 2:
            raise ValueError(f"expected a range [low, high], got {value!r}")
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            raise ValueError(f"expected a range of two numbers, got {value!r}")
        low, high = float(value[0]), float(value[1])
        if not (math.isfinite(low) and math.isfinite(high)):
            raise ValueError(f"the range {list(value)} is not finite")
        if low > high:
            raise ValueError(f"the range {list(value)} is inverted (low > high)")
        return cls(low, high)


@dataclass(frozen=True)
class ObservationTerms:
    """Observation terms by name, given in configs as a list of names (none: the whole observation).
    `columns`, the observation entries they fill, are set when the task is built (`with_observation_columns`)."""

    names: tuple[str, ...] = ()
    columns: tuple[int, ...] | None = None

    @classmethod
    def parse(cls, value: Any) -> ObservationTerms:
        """The ObservationTerms of a list of names; ValueError for anything else."""
        if isinstance(value, ObservationTerms):
            return value
        if not isinstance(value, Sequence) or isinstance(value, str) or not all(isinstance(v, str) for v in value):
            raise ValueError(f"expected a list of observation term names, got {value!r}")
        return cls(tuple(value))

    def resolved(self, layout: Sequence[tuple[str, int]]) -> ObservationTerms:
        """These terms with their columns, from the observation's layout ((name, width) of each observation
        term, in order); ValueError naming the close names and all names for an unknown one."""
        names = [name for name, _ in layout]
        for name in self.names:
            if name not in names:
                close = difflib.get_close_matches(name, names, n=3)
                hint = f" Did you mean: {', '.join(close)}?" if close else ""
                raise ValueError(f"the task has no observation term '{name}'.{hint} Its terms: {', '.join(names)}")
        starts = np.cumsum([0, *(width for _, width in layout)])[:-1]  # each term's first column
        columns = [
            int(start) + k
            for (name, width), start in zip(layout, starts, strict=True)
            if not self.names or name in self.names
            for k in range(width)
        ]
        return replace(self, columns=tuple(columns))


def with_observation_columns(task: str, event: Any, layout: Sequence[tuple[str, int]]) -> Any:
    """The bound event term with each ObservationTerms parameter's columns set from the observation's layout;
    ConfigError for an unknown term name."""
    params = dict(event.params)
    for name, value in event.params.items():
        if isinstance(value, ObservationTerms):
            try:
                params[name] = value.resolved(layout)
            except ValueError as error:
                raise ConfigError(f"task '{task}': event '{event.name}', parameter '{name}': {error}") from None
    return replace(event, params=params)


@dataclass(frozen=True)
class Curriculum:
    """How the training environments' strengths move: by `step_up` after an episode whose `metric` (a task
    metric) ended above 0.5, by `step_down` after one that ended at or below it, within [0, 1]. Strengths
    settle where a fraction step_down / (step_up + step_down) of the episodes succeed, and reach 1 once the
    policy does better than that at full strength."""

    metric: str
    start: float = 0.0
    step_up: float = 0.2
    step_down: float = 0.1

    def __post_init__(self) -> None:
        for name in ("start", "step_up", "step_down"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0.0 <= value <= 1.0):
                raise ValueError(f"{name} must be in [0, 1], got {value}")
        if self.step_up == 0.0:
            raise ValueError("step_up must be above 0, or the strengths never rise")

    def next_strength(self, xp: Any, strength: Any, ended: Any, metric: Any) -> Any:
        """(N,) the strengths after a step on which the episodes `ended` (N,) bool ended with `metric` (N,)."""
        change = xp.where(metric > 0.5, self.step_up, -self.step_down)
        return xp.clip(strength + xp.where(ended, change, 0.0), 0.0, 1.0).astype(strength.dtype)


def default_params(model: Any, observation_size: int) -> dict[str, np.ndarray]:
    """The model's own value of every randomizable quantity (see the module docstring), unbatched."""
    values = {name: np.array(getattr(model, name), dtype=np.float64) for name in MODEL_FIELDS}
    values["geom_rgba"] = _shown_rgba(model)
    values["ctrl_offset"] = np.zeros(model.nu)
    values["action_delay"] = np.zeros((), np.int32)
    values["obs_noise"] = np.zeros(observation_size)
    values["xfrc_applied"] = np.zeros((model.nbody, 6))
    return values


def _shown_rgba(model: Any) -> np.ndarray:
    """(ngeom, 4) the colour each geom shows: its material's where it has one and its own colour is MuJoCo's
    default (0.5, 0.5, 0.5, 1), its own otherwise (the rule of MuJoCo's and MuJoCo Warp's renderers). Written
    as the geom's own colour, it shows the same, and a drawn colour changes that geom alone."""
    rgba = np.array(model.geom_rgba, dtype=np.float64)
    material = np.asarray(model.geom_matid)
    uses_material = (material >= 0) & np.all(rgba == np.array([0.5, 0.5, 0.5, 1.0], dtype=np.float32), axis=1)
    rgba[uses_material] = np.asarray(model.mat_rgba, dtype=np.float64)[material[uses_material]]
    return rgba


def tiled(xp: Any, defaults: Mapping[str, np.ndarray], num_envs: int, names: Any = None) -> dict[str, Any]:
    """`num_envs` copies of the defaults (of `names`, default all) as arrays of `xp`."""
    names = defaults.keys() if names is None else names
    return {name: xp.asarray(np.broadcast_to(defaults[name], (num_envs, *np.shape(defaults[name])))) for name in names}


# --- what backends call -----------------------------------------------------------------------


def episode_params(task: Any, ctx: TermContext) -> dict[str, Any]:
    """The randomized quantities (`task.param_fields`) of new episodes: the defaults with the task's reset
    events applied (`ctx`: the environments starting, with `random` set)."""
    xp = ctx.xp
    ctx = ctx.replace(params=tiled(xp, task.defaults, ctx.num_envs, task.param_fields), defaults=task.defaults)
    for event in task.reset_events:
        ctx = event(ctx)
    return dict(ctx.params)


def step_params(task: Any, ctx: TermContext) -> dict[str, Any]:
    """The randomized quantities after a step (`ctx.episode_step` counting it, `ctx.params` the current
    values, `random` set): a push ends (xfrc_applied back at zero), then each interval event draws anew in
    the environments whose episode step is a multiple of its interval."""
    xp = ctx.xp
    params = dict(ctx.params)
    if "xfrc_applied" in params:
        params["xfrc_applied"] = xp.zeros_like(params["xfrc_applied"])
    ctx = ctx.replace(params=params, defaults=task.defaults)
    for event in task.interval_events:
        due = ctx.episode_step % event.interval == 0
        drawn = event(ctx).params
        ctx = ctx.replace(params={name: _where_env(xp, due, drawn[name], value) for name, value in ctx.params.items()})
    return dict(ctx.params)


def delayed_action(xp: Any, history: Any, action: Any, delay: Any) -> tuple[Any, Any]:
    """(the action each environment's actuators get, the new history): `history` (N, D + 1, nu) holds the
    last actions, newest first; environment i gets the one `delay[i]` steps old."""
    history = xp.concatenate([action[:, None], history[:, :-1]], axis=1)
    return history[xp.arange(history.shape[0]), delay], history


def _where_env(xp: Any, mask: Any, new: Any, old: Any) -> Any:
    return xp.where(mask.reshape(mask.shape + (1,) * (new.ndim - 1)), new, old)


# --- helpers ----------------------------------------------------------------------------------


def _choice(what: str, value: str, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise ValueError(f"unknown {what} '{value}'; use one of {', '.join(choices)}")
    return value


def _sample(ctx: TermContext, shape: tuple[int, ...], span: Range, distribution: str) -> Any:
    """Samples of `span` in the given distribution (log_uniform: uniform in log space, for positive ranges)."""
    if ctx.random is None:
        raise ValueError("an event term needs ctx.random, which backends set while running events")
    if _choice("distribution", distribution, DISTRIBUTIONS) == "log_uniform":
        if span.low <= 0:
            raise ValueError(f"a log_uniform range must be positive, got [{span.low}, {span.high}]")
        return ctx.xp.exp(ctx.random.uniform(shape, math.log(span.low), math.log(span.high)))
    return ctx.random.uniform(shape, span.low, span.high)


def _at_strength(ctx: TermContext, draw: Any, neutral: Any = 0.0) -> Any:
    """`draw` (N, ...) moved toward `neutral` (what leaves the model as it is) by each environment's strength:
    neutral + strength x (draw - neutral); `draw` itself at full strength (ctx.strength None)."""
    if ctx.strength is None:
        return draw
    strength = ctx.strength.reshape(ctx.strength.shape + (1,) * (np.ndim(draw) - 1))
    return neutral + strength * (draw - neutral)


def _drawn(ctx: TermContext, base: Any, span: Range, distribution: str, operation: str) -> Any:
    """`base` (the defaults of some entries, broadcast over the environments) changed by fresh samples, at each
    environment's strength."""
    shape = (ctx.num_envs, *np.shape(base))
    sample = _sample(ctx, shape, span, distribution)
    operation = _choice("operation", operation, OPERATIONS)
    if operation == "scale":
        return base * _at_strength(ctx, sample, 1.0)
    return base + _at_strength(ctx, sample) if operation == "add" else _at_strength(ctx, sample, base)


def _written(ctx: TermContext, name: str, columns: Any, values: Any) -> TermContext:
    """`ctx` with `params[name][:, columns] = values`."""
    return ctx.replace(params={**ctx.params, name: set_columns(ctx.params[name], np.asarray(columns), values)})


# --- model parameters -------------------------------------------------------------------------


def randomize_geom_friction(
    ctx: TermContext,
    geoms: Geoms,
    range: Range = Range(1.0, 1.0),  # noqa: A002 - Isaac Lab's name for it
    distribution: str = "uniform",
    operation: str = "scale",
) -> TermContext:
    """Draw the sliding friction (geom_friction's first column) of each named geom; a contact uses the
    larger of its two geoms' frictions (MuJoCo's default mixing)."""
    ids = np.asarray(geoms.ids)
    sliding = _drawn(ctx, ctx.defaults["geom_friction"][ids, 0], range, distribution, operation)
    current = ctx.params["geom_friction"][:, ids]
    return _written(ctx, "geom_friction", ids, ctx.xp.concatenate([sliding[..., None], current[..., 1:]], axis=-1))


def randomize_body_mass(
    ctx: TermContext,
    bodies: Bodies,
    range: Range = Range(1.0, 1.0),  # noqa: A002
    distribution: str = "uniform",
    operation: str = "scale",
) -> TermContext:
    """Draw the mass of each named body; its rotational inertia changes by the same factor (a body of the
    same shape and density profile), so that its inertia stays physical."""
    ids = np.asarray(bodies.ids)
    default = ctx.defaults["body_mass"][ids]
    if (default <= 0).any():
        raise ValueError(f"bodies {', '.join(bodies.names)} need positive masses to randomize, have {default.tolist()}")
    mass = _drawn(ctx, default, range, distribution, operation)
    if operation != "scale" and range.low + (default.min() if operation == "add" else 0.0) <= 0:
        raise ValueError(f"the range [{range.low}, {range.high}] can make a mass zero or negative")
    factor = mass / default
    inertia = ctx.defaults["body_inertia"][ids] * factor[..., None]
    return _written(_written(ctx, "body_mass", ids, mass), "body_inertia", ids, inertia)


def randomize_actuator_gains(
    ctx: TermContext,
    actuators: Actuators = (),  # type: ignore[assignment]
    kp_range: Range = Range(1.0, 1.0),
    kv_range: Range = Range(1.0, 1.0),
    distribution: str = "uniform",
    operation: str = "scale",
) -> TermContext:
    """Draw the stiffness kp and damping kv of position servos (MJCF <position>): kp is gainprm[0] and
    -biasprm[1], kv is -biasprm[2]; the two are drawn independently (empty actuators: all)."""
    ids = np.asarray(actuators.ids)
    gain, bias = ctx.defaults["actuator_gainprm"][ids], ctx.defaults["actuator_biasprm"][ids]
    if not np.allclose(bias[:, 1], -gain[:, 0]):
        raise ValueError(f"actuators {', '.join(actuators.names)} are not all position servos (biasprm[1] = -kp)")
    kp = _drawn(ctx, gain[:, 0], kp_range, distribution, operation)
    kv = _drawn(ctx, -bias[:, 2], kv_range, distribution, operation)
    gains = ctx.xp.concatenate([kp[..., None], ctx.params["actuator_gainprm"][:, ids, 1:]], axis=-1)
    current = ctx.params["actuator_biasprm"][:, ids]
    biases = ctx.xp.concatenate([current[..., :1], -kp[..., None], -kv[..., None], current[..., 3:]], axis=-1)
    return _written(_written(ctx, "actuator_gainprm", ids, gains), "actuator_biasprm", ids, biases)


def randomize_joint_damping(
    ctx: TermContext,
    joints: Joints = (),  # type: ignore[assignment]
    range: Range = Range(1.0, 1.0),  # noqa: A002
    distribution: str = "uniform",
    operation: str = "scale",
) -> TermContext:
    """Draw the damping of the named joints' dofs (empty: every hinge and slide joint)."""
    return _drawn_dof_field(ctx, "dof_damping", joints, range, distribution, operation)


def randomize_joint_armature(
    ctx: TermContext,
    joints: Joints = (),  # type: ignore[assignment]
    range: Range = Range(1.0, 1.0),  # noqa: A002
    distribution: str = "uniform",
    operation: str = "scale",
) -> TermContext:
    """Draw the armature (rotor inertia) of the named joints' dofs (empty: every hinge and slide joint)."""
    return _drawn_dof_field(ctx, "dof_armature", joints, range, distribution, operation)


def _drawn_dof_field(
    ctx: TermContext,
    field: str,
    joints: Joints,
    range: Range,
    distribution: str,
    operation: str,  # noqa: A002
) -> TermContext:
    """`ctx` with the model's per-dof `field` of the joints' dofs drawn around its default."""
    dofs = np.asarray(joints.dof_index)
    return _written(ctx, field, dofs, _drawn(ctx, ctx.defaults[field][dofs], range, distribution, operation))


# --- appearance -------------------------------------------------------------------------------


def randomize_geom_rgba(
    ctx: TermContext,
    geoms: Geoms,
    red: Range = Range(1.0, 1.0),
    green: Range = Range(1.0, 1.0),
    blue: Range = Range(1.0, 1.0),
    brightness: Range = Range(1.0, 1.0),
    distribution: str = "uniform",
    operation: str = "scale",
) -> TermContext:
    """Draw the colour of each named geom: its red, green and blue each drawn around the colour it shows (with
    `operation`), then all three scaled by one `brightness` factor per geom, clipped to [0, 1]; alpha kept."""
    ids = np.asarray(geoms.ids)
    base = ctx.defaults["geom_rgba"][ids]
    channels = [_drawn(ctx, base[:, c], span, distribution, operation) for c, span in enumerate((red, green, blue))]
    factor = _at_strength(ctx, _sample(ctx, (ctx.num_envs, len(ids), 1), brightness, distribution), 1.0)
    rgb = ctx.xp.clip(ctx.xp.stack(channels, axis=-1) * factor, 0.0, 1.0)
    return _written(ctx, "geom_rgba", ids, ctx.xp.concatenate([rgb, ctx.params["geom_rgba"][:, ids, 3:]], axis=-1))


def randomize_camera_pose(
    ctx: TermContext,
    cameras: SceneCameras,
    position: Range = Range(0.0, 0.0),
    rotation: Range = Range(0.0, 0.0),
) -> TermContext:
    """Move each named camera (fixed in its body) from its pose: an offset uniform in `position` (m) along each
    axis of its body, and a turn by an angle uniform in `rotation` (rad) about each of its own axes (x, y, z
    in turn), as a camera mounted slightly off."""
    _check_fixed("camera", cameras, position, rotation)
    ids = np.asarray(cameras.ids)
    offset = _at_strength(ctx, ctx.random.uniform((ctx.num_envs, len(ids), 3), position.low, position.high))  # type: ignore[union-attr]
    turn = _turn(ctx, (ctx.num_envs, len(ids)), rotation)
    quat = _quat_mul(ctx.xp, ctx.defaults["cam_quat"][ids], turn)
    return _written(_written(ctx, "cam_pos", ids, ctx.defaults["cam_pos"][ids] + offset), "cam_quat", ids, quat)


def randomize_light(
    ctx: TermContext,
    lights: Lights,
    position: Range = Range(0.0, 0.0),
    direction: Range = Range(0.0, 0.0),
    diffuse: Range = Range(1.0, 1.0),
    distribution: str = "uniform",
) -> TermContext:
    """Draw each named light: its position moved by an offset uniform in `position` (m) along each axis of its
    body, its direction turned by an angle uniform in `direction` (rad) about each of those axes (x, y, z in
    turn), its diffuse colour scaled by one factor drawn from `diffuse` (brightness, colour kept)."""
    _check_fixed("light", lights, position, direction)
    ids = np.asarray(lights.ids)
    shape = (ctx.num_envs, len(ids))
    offset = _at_strength(ctx, ctx.random.uniform((*shape, 3), position.low, position.high))  # type: ignore[union-attr]
    turned = _rotated(ctx.xp, _turn(ctx, shape, direction), ctx.xp.asarray(ctx.defaults["light_dir"][ids]))
    factor = _at_strength(ctx, _sample(ctx, (*shape, 1), diffuse, distribution), 1.0)
    ctx = _written(ctx, "light_pos", ids, ctx.defaults["light_pos"][ids] + offset)
    ctx = _written(ctx, "light_dir", ids, turned)
    return _written(ctx, "light_diffuse", ids, ctx.defaults["light_diffuse"][ids] * factor)


def _check_fixed(kind: str, handle: SceneCameras | Lights, *spans: Range) -> None:
    """ValueError where a pose is drawn for a camera or light that is not fixed in its body (one that tracks or
    targets a body has its pose computed from it each step)."""
    moving = [name for name, fixed in zip(handle.names, handle.fixed, strict=True) if not fixed]
    if moving and any(span != Range(0.0, 0.0) for span in spans):
        raise ValueError(f"the pose of {kind} {', '.join(moving)} is not fixed in its body (MJCF mode 'fixed')")


def _turn(ctx: TermContext, shape: tuple[int, ...], span: Range) -> Any:
    """(*shape, 4) unit quaternions: turns about the x, y then z axis, each by an angle uniform in `span` at each
    environment's strength (exactly the identity at strength 0)."""
    xp = ctx.xp
    half = _at_strength(ctx, ctx.random.uniform((*shape, 3), span.low, span.high)) / 2  # type: ignore[union-attr]
    cos, sin, zero = xp.cos(half), xp.sin(half), xp.zeros_like(half[..., 0])
    quat = xp.stack([cos[..., 0], sin[..., 0], zero, zero], axis=-1)
    quat = _quat_mul(xp, quat, xp.stack([cos[..., 1], zero, sin[..., 1], zero], axis=-1))
    return _quat_mul(xp, quat, xp.stack([cos[..., 2], zero, zero, sin[..., 2]], axis=-1))


def _quat_mul(xp: Any, a: Any, b: Any) -> Any:
    """The Hamilton product a b of quaternions (..., 4), w first (MuJoCo's convention)."""
    aw, ax, ay, az = (a[..., i] for i in range(4))
    bw, bx, by, bz = (b[..., i] for i in range(4))
    return xp.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def _rotated(xp: Any, quat: Any, vector: Any) -> Any:
    """`vector` (..., 3) rotated by the unit quaternions `quat` (..., 4): q v q*."""
    vector = xp.broadcast_to(vector, (*quat.shape[:-1], 3))
    pure = xp.concatenate([xp.zeros_like(vector[..., :1]), vector], axis=-1)
    conjugate = quat * xp.asarray([1.0, -1.0, -1.0, -1.0])
    return _quat_mul(xp, _quat_mul(xp, quat, pure), conjugate)[..., 1:]


# --- control and observation ------------------------------------------------------------------


def randomize_joint_offset(
    ctx: TermContext,
    actuators: Actuators = (),  # type: ignore[assignment]
    range: Range = Range(0.0, 0.0),  # noqa: A002
    distribution: str = "uniform",
) -> TermContext:
    """Draw a zero offset of each named servo (rad): added to its target, as a miscalibrated servo whose
    zero is off; the policy's observation is unchanged (it reads the true joint positions)."""
    ids = np.asarray(actuators.ids)
    offset = _sample(ctx, (ctx.num_envs, len(ids)), range, distribution)
    return _written(ctx, "ctrl_offset", ids, _at_strength(ctx, offset))


def observation_noise(
    ctx: TermContext,
    std: float = 0.01,
    distribution: str = "gaussian",
    terms: ObservationTerms = ObservationTerms(),  # noqa: B008 (frozen: one shared instance is safe)
) -> TermContext:
    """Draw noise added to the entries of the observation terms `terms` (default: every entry): std x N(0, 1)
    ("gaussian") or U(-std, std) ("uniform"). Each event draws its own terms' entries and leaves the others,
    so one event per group of terms gives each its own std. As an INTERVAL event with interval_steps 1 it is
    fresh on every step. The policy sees it; a value network may see the observation without it."""
    if not (math.isfinite(std) and std >= 0):
        raise ValueError(f"std must be a finite number >= 0, got {std}")
    if terms.columns is None:
        raise ValueError("the observation terms' columns are set when the task is built")
    shape = (ctx.num_envs, len(terms.columns))
    if _choice("distribution", distribution, ("gaussian", "uniform")) == "uniform":
        noise = ctx.random.uniform(shape, -std, std)  # type: ignore[union-attr]
    else:
        noise = std * ctx.random.normal(shape)  # type: ignore[union-attr]
    return _written(ctx, "obs_noise", terms.columns, _at_strength(ctx, noise))


def action_delay(ctx: TermContext, range: Range = Range(0.0, 0.0)) -> TermContext:  # noqa: A002
    """Draw each environment's action delay, a whole number of control steps in [low, high]: the actuators
    get the action of that many steps ago (zeros before the episode's first). Below full strength the delay
    is rounded up or down at random to a whole number whose mean is strength x the draw."""
    if range.low < 0 or range.low != int(range.low) or range.high != int(range.high):
        raise ValueError(f"the delay range must be whole numbers of steps >= 0, got [{range.low}, {range.high}]")
    draw = ctx.random.uniform((ctx.num_envs,), range.low, range.high + 1.0)  # type: ignore[union-attr]
    delay = ctx.xp.minimum(ctx.xp.floor(draw), range.high)
    if ctx.strength is not None:
        delay = ctx.xp.floor(_at_strength(ctx, delay) + ctx.random.uniform((ctx.num_envs,)))  # type: ignore[union-attr]
    return ctx.replace(params={**ctx.params, "action_delay": delay.astype(ctx.params["action_delay"].dtype)})


def push_body(
    ctx: TermContext, body: Body, force: Range = Range(0.0, 0.0), torque: Range = Range(0.0, 0.0)
) -> TermContext:
    """Push a body for one control step: each component of the force (N) and torque (N m) in world axes
    uniform in its range, applied at the body's centre of mass (an impulse of force x control dt)."""
    wrench = ctx.xp.concatenate(
        [ctx.random.uniform((ctx.num_envs, 3), span.low, span.high) for span in (force, torque)],  # type: ignore[union-attr]
        axis=1,
    )
    return _written(ctx, "xfrc_applied", [body.id], _at_strength(ctx, wrench)[:, None, :])


def randomization_strength(ctx: TermContext) -> Any:
    """(N,) the strength each environment draws its events at (1 without a curriculum): the metric a
    curriculum adds to its task, so that training reports how far the randomization has come."""
    if ctx.strength is None:
        return ctx.xp.ones(ctx.num_envs)
    return ctx.strength


CURRICULUM_METRIC = randomization_strength.__name__

RANDOMIZATION_TERMS: dict[str, Callable[..., Any]] = {
    function.__name__: function
    for function in (
        randomize_geom_friction,
        randomize_body_mass,
        randomize_actuator_gains,
        randomize_joint_damping,
        randomize_joint_armature,
        randomize_geom_rgba,
        randomize_camera_pose,
        randomize_light,
        randomize_joint_offset,
        observation_noise,
        action_delay,
        push_body,
        randomization_strength,
    )
}
