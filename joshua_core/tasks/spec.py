"""Task specifications: which terms a task composes, with weights and parameters, as plain data.

A `TaskSpec` names its terms (registered through `joshua_register_terms`) by kind; plugins
register specs through `joshua_register_tasks`. `with_config` lays a `TaskConfig` from the
training config over a spec: change a term's weight (0 disables it) or parameters, or add a
registered term the task does not have.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from joshua_core.errors import ConfigError
from joshua_core.tasks.cameras import CameraSpec, camera_spec
from joshua_core.tasks.randomization import CURRICULUM_METRIC, Curriculum


class TermKind(enum.Enum):
    """Where a term is used in a task, and what it returns."""

    OBSERVATION = "observation"  # (N,) or (N, k) values, concatenated into the observation
    REWARD = "reward"  # (N,) values, weighted and summed into the reward
    TERMINATION = "termination"  # (N,) bool, any true ends the episode (terminated)
    RESET = "reset"  # a new TermContext with randomised state, applied in order at reset
    METRIC = "metric"  # (N,) values reported in infos["metrics"], not part of the reward
    EVENT = "event"  # a new TermContext with randomised ctx.params (domain randomization), see EventSpec


@dataclass(frozen=True)
class TermSpec:
    """One use of a registered term in a task: `term` is the registered name, `name` the name in the task."""

    term: str
    weight: float = 1.0
    params: Mapping[str, Any] = field(default_factory=dict)
    name: str = ""

    @property
    def key(self) -> str:
        """The name this use is reported and overridden under (`name`, else the term's name)."""
        return self.name or self.term


@dataclass(frozen=True)
class EventSpec(TermSpec):
    """A domain-randomization event: an event term (see joshua_core.tasks.randomization) that runs when an
    episode starts (`mode` "reset") or every `interval` steps of an episode (`mode` "interval")."""

    mode: str = "reset"
    interval: int = 0


EVENT_MODES = ("reset", "interval")


@dataclass(frozen=True)
class ActionSpec:
    """How a policy action in [-1, 1] becomes actuator controls.

    - "ctrl_range": mapped affinely onto each actuator's ctrlrange (motors: ctrl = action).
    - "offset": ctrl = initial ctrl (the keyframe's) + scale * action, clipped to ctrlrange
      (position servos: the action moves the targets around the home pose).
    - "delta": ctrl = the controls in force + scale * action, clipped to ctrlrange, starting from the
      initial ctrl at each reset (position servos: the action moves the targets by at most `scale` per
      step, so exploration is smooth; observe the targets, e.g. with the `servo_error` term).
    """

    mode: str = "ctrl_range"
    scale: float = 1.0


@dataclass(frozen=True)
class TaskSpec:
    """A task: terms by kind, the model it is written for, and the episode structure."""

    name: str
    summary: str
    model_path: str
    frame_skip: int
    episode_length: int
    observations: tuple[TermSpec, ...] = ()
    rewards: tuple[TermSpec, ...] = ()
    terminations: tuple[TermSpec, ...] = ()
    resets: tuple[TermSpec, ...] = ()
    metrics: tuple[TermSpec, ...] = ()
    events: tuple[EventSpec, ...] = ()  # domain randomization, applied in order
    commands: Mapping[str, int] = field(default_factory=dict)  # per-env task variables and their sizes
    keyframe: str = ""  # initial state; empty: the model's defaults
    action: ActionSpec = ActionSpec()
    curriculum: Curriculum | None = None  # eases the events in on training environments; None: full strength
    cameras: tuple[CameraSpec, ...] = ()  # scene cameras rendered as image observations (joshua_core.tasks.cameras)
    # other names the task goes by (Isaac Lab's `AntEnv`), declared by the plugin that provides it, so that a
    # convenience such as `from joshua_sb3 import AntEnv` finds the task without naming another plugin's tasks
    aliases: tuple[str, ...] = ()

    def terms(self, kind: TermKind) -> tuple[TermSpec, ...]:
        return getattr(self, _FIELD_OF_KIND[kind])


_FIELD_OF_KIND = {
    TermKind.OBSERVATION: "observations",
    TermKind.REWARD: "rewards",
    TermKind.TERMINATION: "terminations",
    TermKind.RESET: "resets",
    TermKind.METRIC: "metrics",
    TermKind.EVENT: "events",
}


ACTION_MODES = ("ctrl_range", "offset", "delta")


def _action(spec: TaskSpec, action: Any) -> ActionSpec:
    """The task's ActionSpec with a `joshua.ActionConfig`'s mode and scale where they are set (the mode is
    checked where it is used: `actuation.action_mapping`)."""
    if action.scale < 0 or not math.isfinite(action.scale):
        raise ConfigError(f"task '{spec.name}': action scale must be a positive finite number, got {action.scale}")
    return ActionSpec(action.mode or spec.action.mode, action.scale or spec.action.scale)


def parse_param(text: str) -> Any:
    """A term parameter from config text: JSON (numbers, lists, true/false, "quoted"), else the bare string."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError:
        return text
    except (RecursionError, ValueError) as error:  # json recurses once per level; int() refuses 4300+ digits
        reason = "nests too deeply" if isinstance(error, RecursionError) else str(error)
        raise ConfigError(f"term parameter {text[:40]!r}...: {reason}") from None
    return tuple(value) if isinstance(value, list) else value


def with_config(spec: TaskSpec, config: Any) -> TaskSpec:
    """`spec` with a `joshua.TaskConfig` message laid over it (episode length, frame skip, keyframe, term overrides,
    events, cameras added to the task's)."""
    changes: dict[str, Any] = {}
    if config.episode_length < 0 or config.frame_skip < 0:
        raise ConfigError(f"task '{spec.name}': episode_length and frame_skip must not be negative")
    if config.episode_length:
        changes["episode_length"] = config.episode_length
    if config.frame_skip:
        changes["frame_skip"] = config.frame_skip
    if config.keyframe:
        changes["keyframe"] = config.keyframe
    if config.action.mode or config.action.scale:
        changes["action"] = _action(spec, config.action)
    term_lists = {kind: list(spec.terms(kind)) for kind in TermKind}
    for override in config.terms:
        _apply_override(spec, term_lists, override)
    for kind, terms in term_lists.items():
        changes[_FIELD_OF_KIND[kind]] = tuple(terms)
    changes["events"] += tuple(_event(spec, event) for event in config.events)
    names = [event.key for event in changes["events"]]
    duplicates = sorted({name for name in names if names.count(name) > 1})
    if duplicates:
        raise ConfigError(f"task '{spec.name}': events {', '.join(map(repr, duplicates))} appear more than once")
    if config.HasField("randomization_curriculum"):
        changes["curriculum"] = _curriculum(spec, config.randomization_curriculum, changes)
        changes["metrics"] += (TermSpec(CURRICULUM_METRIC),)
    changes["cameras"] = spec.cameras + tuple(camera_spec(camera) for camera in config.cameras)
    return dataclasses.replace(spec, **changes)


def _curriculum(spec: TaskSpec, config: Any, changes: dict[str, Any]) -> Curriculum:
    """The Curriculum of a `joshua.RandomizationCurriculum`, checked against the task's events and metrics."""
    where = f"task '{spec.name}': randomization_curriculum"
    if not changes["events"]:
        raise ConfigError(f"{where}: the task has no events to ease in; add events or remove the curriculum")
    metrics = [term.key for term in changes["metrics"]]
    if config.metric not in metrics:
        raise ConfigError(f"{where}: metric '{config.metric}' is not one of the task's metrics: {', '.join(metrics)}")
    given = {name: getattr(config, name) for name in ("start", "step_up", "step_down") if config.HasField(name)}
    try:
        return Curriculum(config.metric, **given)
    except ValueError as error:
        raise ConfigError(f"{where}: {error}") from None


def _event(spec: TaskSpec, event: Any) -> EventSpec:
    """An EventSpec from a `joshua.EventConfig`."""
    where = f"task '{spec.name}': event '{event.name}'"
    if not event.name or not event.term:
        raise ConfigError(f"{where}: give both `name` and `term` (a registered event term)")
    mode = type(event).Mode.Name(event.mode).lower()
    if mode not in EVENT_MODES:
        raise ConfigError(f"{where}: set `mode` to RESET or INTERVAL")
    if mode == "interval" and event.interval_steps < 1:
        raise ConfigError(f"{where}: an INTERVAL event needs interval_steps of at least 1, got {event.interval_steps}")
    params = {key: parse_param(value) for key, value in event.params.items()}
    return EventSpec(event.term, 1.0, params, event.name, mode, event.interval_steps if mode == "interval" else 0)


def _apply_override(spec: TaskSpec, term_lists: dict[TermKind, list[TermSpec]], override: Any) -> None:
    """Change the term named `override.name`, or add it when `override.term` and `override.kind` say what."""
    params = {key: parse_param(value) for key, value in override.params.items()}
    matches = [
        (kind, i) for kind, terms in term_lists.items() for i, term in enumerate(terms) if term.key == override.name
    ]
    if matches:
        kind, index = matches[0]
        term = term_lists[kind][index]
        if override.term and override.term != term.term:
            raise ConfigError(
                f"task '{spec.name}': term '{override.name}' is '{term.term}'; to add another term, give it a new name"
            )
        weight = override.weight if override.HasField("weight") else term.weight
        term_lists[kind][index] = dataclasses.replace(term, weight=weight, params={**term.params, **params})
        return
    kind_name = type(override).Kind.Name(override.kind) if override.kind else ""
    if not override.term or not kind_name:
        known = ", ".join(term.key for terms in term_lists.values() for term in terms)
        raise ConfigError(
            f"task '{spec.name}' has no term '{override.name}' (its terms: {known}); to add a term, "
            "also give `term` (a registered term) and `kind` (OBSERVATION, REWARD, TERMINATION, RESET or METRIC)"
        )
    kind = TermKind[kind_name]
    weight = override.weight if override.HasField("weight") else 1.0
    term_lists[kind].append(TermSpec(override.term, weight, params, override.name))
