"""The task layer: terms, task specifications and built tasks, shared by every backend.

A term is a pure function `term(ctx, **params)` of a `TermContext` (batched state + array
namespace `ctx.xp`), so the same task runs on numpy (joshua-mujoco) and inside `jax.jit`
(joshua-mjx). See docs/tasks.md.
"""

from joshua_core.tasks.context import STATE_FIELDS, JaxRandom, NumpyRandom, RandomSource, TermContext, set_columns
from joshua_core.tasks.episodes import Episode, EpisodeSums, StepOutcome, account_step, nonfinite
from joshua_core.tasks.handles import Actuators, Body, Joint, Joints, Sensor, Site
from joshua_core.tasks.spec import ActionSpec, TaskSpec, TermKind, TermSpec, parse_param, with_config
from joshua_core.tasks.task import BoundTerm, Task, build_task, load_task_spec

__all__ = [
    "STATE_FIELDS",
    "ActionSpec",
    "Actuators",
    "Body",
    "BoundTerm",
    "Episode",
    "EpisodeSums",
    "JaxRandom",
    "Joint",
    "Joints",
    "NumpyRandom",
    "RandomSource",
    "Sensor",
    "Site",
    "StepOutcome",
    "Task",
    "TaskSpec",
    "TermContext",
    "TermKind",
    "TermSpec",
    "account_step",
    "build_task",
    "load_task_spec",
    "nonfinite",
    "parse_param",
    "set_columns",
    "with_config",
]
