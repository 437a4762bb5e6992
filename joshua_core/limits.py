"""Finite-number and size checks of every numeric config field, core fields and plugin options alike.

`check_numbers` walks a config message generically: any float or double field (set extensions
included) holding NaN or an infinity is an error, and the fields of `BOUNDS` must lie in their range.
Modes and trainers can then trust the numbers they read: a NaN duration or a 1e9 fps is a one-line
error (exit 2) before any memory is allocated or any loop starts, not a traceback or a hang later.
Bounds are keyed by the field's full protobuf name, so plugin options are listed here as strings
(the core imports no plugin); 0 keeps meaning "the default" wherever the schema says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from google.protobuf.descriptor import FieldDescriptor
from google.protobuf.message import Message

from joshua_core.errors import ConfigError

MAX_FPS = 1000.0  # frames per second of a recorded or shown video: more exhausts memory/disk, helps nobody
MAX_IMAGE_SIDE = 8192  # pixels; MuJoCo's offscreen buffer and the video encoder's practical limit
MAX_REPLAY_SPEED = 1e6  # multiple of real time


@dataclass(frozen=True)
class Bound:
    """The range a numeric field must lie in (both ends inclusive); None: no limit on that side."""

    minimum: float | None = 0.0
    maximum: float | None = None


_FLOAT_TYPES = (FieldDescriptor.TYPE_FLOAT, FieldDescriptor.TYPE_DOUBLE)

# The one table of numeric limits, by full field name. A negative count, size or rate makes no sense;
# an upper bound is declared where a huge value would exhaust memory or hang.
BOUNDS: dict[str, Bound] = {
    "joshua.SimulationConfig.render_width": Bound(0, MAX_IMAGE_SIDE),
    "joshua.SimulationConfig.render_height": Bound(0, MAX_IMAGE_SIDE),
    "joshua.SimulationConfig.duration": Bound(0),
    **{
        f"joshua.TrainingConfig.{name}": Bound(0)
        for name in (  # num_envs is checked where environments are made (EnvSpec)
            "total_timesteps",
            "num_steps",
            "num_epochs",
            "minibatch_size",
            "learning_rate",
            "gamma",
            "gae_lambda",
            "clip_epsilon",
        )
    },
    "joshua_modes.OffscreenOptions.fps": Bound(0, MAX_FPS),
    "joshua_modes.ViewerOptions.fps": Bound(0, MAX_FPS),
    "joshua_modes.ReplayOptions.speed": Bound(0, MAX_REPLAY_SPEED),
    "joshua_modes.ReplayOptions.velocity_limit": Bound(0),
    "joshua_modes.ReplayOptions.penetration_threshold": Bound(0),
    "joshua_mirror.MirrorOptions.display_fps": Bound(0, MAX_FPS),
}


def check_numbers(message: Message, source: str, prefix: str = "") -> None:
    """Raise ConfigError naming the first field of `message` (recursively) that is not finite or out of bounds."""
    for field, value in message.ListFields():
        path = f"{prefix}{field.name}"
        if field.type == FieldDescriptor.TYPE_MESSAGE:
            if field.message_type.GetOptions().map_entry:
                for key, item in value.items():
                    if isinstance(item, Message):
                        check_numbers(item, source, f"{path}[{key}].")
            elif field.is_repeated:
                for index, item in enumerate(value):
                    check_numbers(item, source, f"{path}[{index}].")
            else:
                check_numbers(value, source, f"{path}.")
            continue
        items = list(enumerate(value)) if field.is_repeated else [(None, value)]
        for index, item in items:
            where = path if index is None else f"{path}[{index}]"
            _check_value(field, item, f"{source}: {where}")


def _check_value(field: FieldDescriptor, value: object, where: str) -> None:
    """One scalar value against the finite rule (floats) and the field's bound, if it has one."""
    if field.type in _FLOAT_TYPES and not math.isfinite(value):  # type: ignore[arg-type]
        raise ConfigError(f"{where}: must be finite, got {value}")
    bound = BOUNDS.get(field.full_name)
    if bound is None or not isinstance(value, (int, float)):
        return
    if bound.minimum is not None and value < bound.minimum:
        raise ConfigError(f"{where}: must be at least {bound.minimum:g}, got {value:g}")
    if bound.maximum is not None and value > bound.maximum:
        raise ConfigError(f"{where}: must be at most {bound.maximum:g}, got {value:g}")
