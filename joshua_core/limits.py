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
from collections.abc import Callable
from dataclasses import dataclass

from google.protobuf.descriptor import FieldDescriptor
from google.protobuf.message import Message

from joshua_core.errors import ConfigError, UsageError

MAX_FPS = 1000.0  # frames per second of a recorded or shown video: more exhausts memory/disk, helps nobody
MAX_IMAGE_SIDE = 8192  # pixels; MuJoCo's offscreen buffer and the video encoder's practical limit
MAX_REPLAY_SPEED = 1e6  # multiple of real time
MIN_FPS = 1.0  # a set video rate below one frame per second leaves a replay with (almost) no frames
MIN_IMAGE_SIDE = 16  # pixels; smaller images are not a picture and the video encoder refuses some of them
MAX_LAYER_WIDTH = 65536  # units of one hidden layer: a wider one exhausts memory before it learns anything
MIN_CONTROL_HZ = 1.0  # control steps per second: a slower loop does not hold a robot
MAX_CONTROL_HZ = 10000.0  # messages or control steps per second: beyond what a ROS 2 node in Python keeps up with
MAX_WAIT_S = 3600.0  # seconds a command waits for a peer before giving up: an hour is a hang, not a wait


@dataclass(frozen=True)
class Bound:
    """The range a numeric field must lie in (both ends inclusive); None: no limit on that side.
    `zero_is_default`: 0 is also accepted, where the schema says it means the default."""

    minimum: float | None = 0.0
    maximum: float | None = None
    zero_is_default: bool = False


_FLOAT_TYPES = (FieldDescriptor.TYPE_FLOAT, FieldDescriptor.TYPE_DOUBLE)

# The one table of numeric limits, by full field name. A negative count, size or rate makes no sense;
# an upper bound is declared where a huge value would exhaust memory or hang.
BOUNDS: dict[str, Bound] = {
    "joshua.SimulationConfig.render_width": Bound(MIN_IMAGE_SIDE, MAX_IMAGE_SIDE, zero_is_default=True),
    "joshua.SimulationConfig.render_height": Bound(MIN_IMAGE_SIDE, MAX_IMAGE_SIDE, zero_is_default=True),
    "joshua.SimulationConfig.duration": Bound(0),
    **{
        f"joshua.TrainingConfig.{name}": Bound(0)
        for name in (  # num_envs is checked where environments are made (EnvSpec)
            "total_timesteps",
            "num_steps",
            "num_epochs",
            "minibatch_size",
            "learning_rate",
            "clip_epsilon",
        )
    },
    "joshua.TrainingConfig.gamma": Bound(0, 1),  # a discount: above 1 returns grow without bound
    "joshua.TrainingConfig.gae_lambda": Bound(0, 1),  # GAE's weight of longer returns: above 1 advantages diverge
    "joshua_modes.OffscreenOptions.fps": Bound(MIN_FPS, MAX_FPS, zero_is_default=True),
    "joshua_modes.ViewerOptions.fps": Bound(MIN_FPS, MAX_FPS, zero_is_default=True),
    "joshua_modes.ReplayOptions.speed": Bound(0, MAX_REPLAY_SPEED),
    "joshua_modes.ReplayOptions.velocity_limit": Bound(0),
    "joshua_modes.ReplayOptions.penetration_threshold": Bound(0),
    "joshua_mirror.MirrorOptions.display_fps": Bound(0, MAX_FPS),
    "joshua_mirror.MirrorOptions.stale_timeout": Bound(0),
    "joshua.TrainingConfig.hidden_sizes": Bound(1, MAX_LAYER_WIDTH),
    "joshua_ppo.PpoOptions.value_hidden_sizes": Bound(1, MAX_LAYER_WIDTH),
    "joshua_ppo.Distributed.num_processes": Bound(0),
    "joshua_ppo.Distributed.process_id": Bound(0),
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
        for position, item in items:
            where = path if position is None else f"{path}[{position}]"
            _check_value(field, item, f"{source}: {where}")


def _check_value(field: FieldDescriptor, value: object, where: str) -> None:
    """One scalar value against the finite rule (floats), its enum's values (an open enum takes any number) and
    the field's bound, if it has one."""
    if field.type in _FLOAT_TYPES and not math.isfinite(value):  # type: ignore[arg-type]
        raise ConfigError(f"{where}: must be finite, got {value}")
    if field.type == FieldDescriptor.TYPE_ENUM and value not in field.enum_type.values_by_number:
        names = ", ".join(item.name for item in field.enum_type.values)
        raise ConfigError(f"{where}: {value} is not one of {names}")
    bound = BOUNDS.get(field.full_name)
    if bound is None or not isinstance(value, (int, float)) or (bound.zero_is_default and value == 0):
        return
    if bound.minimum is not None and value < bound.minimum:
        default = "0 (the default) or " if bound.zero_is_default else ""
        raise ConfigError(f"{where}: must be {default}at least {bound.minimum:g}, got {value:g}")
    if bound.maximum is not None and value > bound.maximum:
        raise ConfigError(f"{where}: must be at most {bound.maximum:g}, got {value:g}")


def cli_number(
    option: str, minimum: float, maximum: float, *, integer: bool = False, above: bool = False
) -> Callable[[str], float]:
    """An argparse `type=` for `option`: a finite number (an integer with `integer`) from `minimum` (excluded
    with `above`) to `maximum`. A bad value is a UsageError, which argparse lets through to the CLI's one-line
    report (exit 2), before the command does any work."""
    lower = f"above {minimum:g}" if above else f"at least {minimum:g}"
    wanted = f"{'an integer' if integer else 'a number'} {lower} and at most {maximum:g}"

    def parse(text: str) -> float:
        try:
            value = float(text)
            if integer and value.is_integer():
                value = int(value)
        except ValueError:
            raise UsageError(f"{option} takes {wanted}, got '{text}'") from None
        low_ok = value > minimum if above else value >= minimum
        if (integer and not isinstance(value, int)) or not (low_ok and value <= maximum):  # NaN fails too
            raise UsageError(f"{option} takes {wanted}, got '{text}'")
        return value

    return parse


def check_one_iteration(total_timesteps: int, num_envs: int, num_steps: int, unrolls: int = 1) -> None:
    """A trainer runs whole iterations of num_envs x num_steps (x unrolls) environment steps, so a
    `total_timesteps` below one iteration would silently run the whole iteration: a ConfigError naming both."""
    iteration = num_envs * num_steps * unrolls
    if total_timesteps >= iteration:
        return
    unrolled = f" x training.ppo.unrolls_per_iteration {unrolls}" if unrolls != 1 else ""
    raise ConfigError(
        f"training.total_timesteps {total_timesteps} is less than one iteration's environment steps, "
        f"training.num_envs {num_envs} x training.num_steps {num_steps}{unrolled} = {iteration}: "
        f"set training.total_timesteps to at least {iteration}, or lower training.num_steps or training.num_envs"
    )
