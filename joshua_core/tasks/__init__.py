"""The task layer: terms, task specifications and built tasks, shared by every backend.

A term is a pure function `term(ctx, **params)` of a `TermContext` (batched state + array
namespace `ctx.xp`), so the same task runs on numpy (joshua-mujoco) and inside `jax.jit`
(joshua-mjx). See docs/tasks.md.
"""

from joshua_core.tasks.cameras import CAMERA_KINDS, Camera, CameraSpec
from joshua_core.tasks.context import (
    DERIVED_FIELDS,
    KINEMATIC_FIELDS,
    STATE_FIELDS,
    JaxRandom,
    NumpyRandom,
    RandomSource,
    TermContext,
    set_columns,
)
from joshua_core.tasks.episodes import (
    MAX_POSITION,
    MAX_SPEED,
    METRIC_PREFIX,
    REWARD_PREFIX,
    Episode,
    EpisodeSums,
    StepOutcome,
    account_step,
    nonfinite,
)
from joshua_core.tasks.handles import (
    Actuators,
    Bodies,
    Body,
    Geoms,
    Joint,
    Joints,
    Lights,
    SceneCameras,
    Sensor,
    Site,
    Touch,
)
from joshua_core.tasks.randomization import (
    INERTIAL_FIELDS,
    MODEL_FIELDS,
    Curriculum,
    Range,
    delayed_action,
    episode_params,
    step_params,
    tiled,
)
from joshua_core.tasks.spec import ActionSpec, EventSpec, TaskSpec, TermKind, TermSpec, parse_param, with_config
from joshua_core.tasks.task import BoundTerm, Task, build_task, load_task_spec

__all__ = [
    "CAMERA_KINDS",
    "DERIVED_FIELDS",
    "INERTIAL_FIELDS",
    "KINEMATIC_FIELDS",
    "MAX_POSITION",
    "MAX_SPEED",
    "METRIC_PREFIX",
    "MODEL_FIELDS",
    "REWARD_PREFIX",
    "STATE_FIELDS",
    "ActionSpec",
    "Actuators",
    "Bodies",
    "Body",
    "BoundTerm",
    "Camera",
    "CameraSpec",
    "Curriculum",
    "Episode",
    "EpisodeSums",
    "EventSpec",
    "Geoms",
    "JaxRandom",
    "Joint",
    "Joints",
    "Lights",
    "NumpyRandom",
    "RandomSource",
    "Range",
    "SceneCameras",
    "Sensor",
    "Site",
    "StepOutcome",
    "Task",
    "TaskSpec",
    "TermContext",
    "TermKind",
    "TermSpec",
    "Touch",
    "account_step",
    "build_task",
    "delayed_action",
    "episode_params",
    "load_task_spec",
    "nonfinite",
    "parse_param",
    "set_columns",
    "step_params",
    "tiled",
    "with_config",
]
