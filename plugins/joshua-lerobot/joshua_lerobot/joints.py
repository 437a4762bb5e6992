"""The one table between LeRobot's joint names and units and the model's, both ways (`LeRobotUnits`).

SO-100/SO-101 (`so100_follower`, `so101_follower`) datasets name the arm's joints `shoulder_pan.pos` ...
`wrist_roll.pos` and the gripper `gripper.pos`. lerobot's motor bus (`MotorsBus._normalize`) reads a servo's
ticks t, within the calibrated range [range_min, range_max] (mid its middle), as
- DEGREES (`use_degrees=True`, the body joints' default): (t - mid) * 360 / 4095;
- RANGE_M100_100 (`use_degrees=False`, body joints): (t - range_min) / (range_max - range_min) * 200 - 100;
- RANGE_0_100 (the gripper, either way): (t - range_min) / (range_max - range_min) * 100;
the two ranges negated (100 - x for the gripper) when the motor's drive_mode is set. The homing offset is
written into the servo, so ticks are read with it applied and no formula needs it.
JOSHUA's SO-ARM100 (models/so_arm100/so_arm100.xml) has joint_1 .. joint_6 in radians, its SO-101
(models/so101/so101.xml, so101_follower) the motors' own names; both have the calibrated SO-10x ranges, a tick is
2 pi / 4095 rad as lerobot's degrees count it, and the middle of the calibrated range is the middle of the model
joint's range (docs/sim-to-real.md, "Joint zeros", and docs/so101.md). So a body
angle a (degrees) is mid + radians(a), a body value r (range) mid + r / 100 * half span of the calibrated
range, and the gripper g low + g / 100 * (high - low) over the model's range, or over the calibrated range
when a calibration is given. Directions are taken to agree (the SO-ARM100 follows the SO-100 URDF's axes, the
SO-101 those of TheRobotStudio's so101_new_calib.xml, written for LeRobot's calibration).
Any other feature name `<joint>.pos` is a joint of the model in the model's own units.

The real arm's angle then becomes the model's as the mirror's mapping says (`TopicMapping.offset`, radians):
sim joint position = robot value + offset.
"""

from __future__ import annotations

import argparse
import enum
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from joshua_core.errors import UsageError
from joshua_core.json_files import read_json_object
from joshua_core.trajectory import MAX_MAGNITUDE, TrajectoryError


class TopicMapping(Protocol):
    """What an offset is read from: one of the mirror's mappings (joshua-mirror's option
    `simulation.mirror_topic_mappings`), read by name, since this plugin does not depend on the mirror."""

    mujoco_actuator: str
    offset: float


SO100_ROBOT_TYPE = "so100_follower"
SO100_JOINTS = {
    "shoulder_pan.pos": "joint_1",
    "shoulder_lift.pos": "joint_2",
    "elbow_flex.pos": "joint_3",
    "wrist_flex.pos": "joint_4",
    "wrist_roll.pos": "joint_5",
    "gripper.pos": "joint_6",
}
SO101_ROBOT_TYPE = "so101_follower"
SO101_JOINTS = {name: name.removesuffix(".pos") for name in SO100_JOINTS}  # the SO-101 model names joints as motors
ARM_JOINTS = {SO100_ROBOT_TYPE: SO100_JOINTS, SO101_ROBOT_TYPE: SO101_JOINTS}  # robot type -> feature -> model joint
GRIPPER = "gripper.pos"
GRIPPER_SCALE = 100.0  # LeRobot's gripper: 0 .. 100 over the range
RANGE_SCALE = 100.0  # LeRobot's body joints without degrees: -100 .. 100 over the range
TICKS_PER_TURN = 4095  # lerobot's degrees: the STS3215's resolution (4096) - 1 ticks per 360 degrees
MAX_TICK = 4095  # the STS3215 reads positions 0..4095
MIN_CALIBRATED_SPAN = TICKS_PER_TURN // 360  # ticks: a calibrated range narrower than a degree is no joint's travel
CALIBRATION_FIELDS = ("id", "drive_mode", "homing_offset", "range_min", "range_max")
POSITION_SUFFIX = ".pos"
# Largest magnitude an SO-100 value (arm angle in degrees, gripper in percent) may have: ±1e4 degrees is
# 28 turns, beyond any joint's travel, so a larger value is a corrupt file, not a pose.
MAX_SO100_VALUE = 1e4


def feature_names(joint_names: Sequence[str]) -> tuple[list[str], str | None]:
    """LeRobot names for the model joints `joint_names`, and the robot type: an SO follower's when the joints are
    exactly the SO-ARM100's or the SO-101's six, else `<joint>.pos` each (and no robot type)."""
    for robot_type, table in ARM_JOINTS.items():
        by_joint = {joint: name for name, joint in table.items()}
        if sorted(joint_names) == sorted(by_joint):
            return [by_joint[joint] for joint in joint_names], robot_type
    return [joint + POSITION_SUFFIX for joint in joint_names], None


def model_joint(name: str, joints: Mapping[str, tuple[float, float]]) -> str:
    """The model joint a LeRobot feature name stands for (the arm's whose joint the model has); a name matching
    none is a TrajectoryError."""
    arms = (table[name] for table in ARM_JOINTS.values() if name in table and table[name] in joints)
    joint = next(arms, name.removesuffix(POSITION_SUFFIX))
    if joint not in joints:
        raise TrajectoryError(
            f"the dataset's joint '{name}' matches no joint of the model (expected '<joint>{POSITION_SUFFIX}' or one "
            f"of {', '.join(SO100_JOINTS)}); the model's joints: {', '.join(joints)}"
        )
    return joint


def plausible_bound(name: str) -> float:
    """The largest magnitude a value of feature `name` may have in LeRobot's units: SO-100's degrees or percent
    up to `MAX_SO100_VALUE`; a joint in the model's own units up to the bound of trajectory files."""
    return MAX_SO100_VALUE if name in SO100_JOINTS else MAX_MAGNITUDE


class BodyUnits(enum.StrEnum):
    """The unit of the SO-100's body joints, as `use_degrees` of lerobot's follower config chooses it."""

    DEGREES = "degrees"  # use_degrees=True: MotorNormMode.DEGREES
    RANGE = "range"  # use_degrees=False: MotorNormMode.RANGE_M100_100


@dataclass(frozen=True)
class MotorRange:
    """One motor of a LeRobot calibration file: its calibrated range in ticks and its drive mode."""

    range_min: int
    range_max: int
    drive_mode: int = 0

    @property
    def half_span(self) -> float:
        """Half the calibrated range in radians (ticks at lerobot's 360 / 4095 degrees each)."""
        return (self.range_max - self.range_min) / 2 * 2 * math.pi / TICKS_PER_TURN


def read_calibration(path: Path) -> dict[str, MotorRange]:
    """A LeRobot calibration JSON (`lerobot-calibrate` writes it, e.g.
    ~/.cache/huggingface/lerobot/calibration/robots/so100_follower/<id>.json): motor name -> {id, drive_mode,
    homing_offset, range_min, range_max}; every SO-100 motor must be there. A problem is one UsageError; a range
    no STS3215 arm has (outside 0..4095 ticks, or under a degree wide) is read and warned about in one line."""
    data = read_json_object(path, "the LeRobot calibration")
    motors = [name.removesuffix(POSITION_SUFFIX) for name in SO100_JOINTS]
    missing = [motor for motor in motors if motor not in data]
    if missing:
        raise UsageError(f"{path}: the LeRobot calibration has no motor {', '.join(missing)}")
    calibration = {}
    for motor in motors:
        entry = data[motor]
        bad = [key for key in CALIBRATION_FIELDS if not _is_int(entry.get(key) if isinstance(entry, dict) else None)]
        if bad:
            raise UsageError(f"{path}: motor '{motor}': {', '.join(bad)} missing or not an integer")
        if entry["range_max"] <= entry["range_min"]:
            low, high = entry["range_min"], entry["range_max"]
            raise UsageError(f"{path}: motor '{motor}': range_max {high} is not above range_min {low}")
        calibration[motor] = MotorRange(entry["range_min"], entry["range_max"], entry["drive_mode"])
        _warn_unlikely_range(path, motor, calibration[motor])
    return calibration


def _warn_unlikely_range(path: Path, motor: str, motor_range: MotorRange) -> None:
    """One line on stderr when `motor_range` is not one an SO-100's servos give: ticks outside 0..4095, or a span
    under a degree, which scales every range value of the motor by its tiny width (a typo read silently before)."""
    low, high = motor_range.range_min, motor_range.range_max
    if low < 0 or high > MAX_TICK:
        problem = f"lies outside the servo's 0..{MAX_TICK} ticks"
    elif high - low < MIN_CALIBRATED_SPAN:
        problem = f"spans {high - low} tick(s), under a degree"
    else:
        return
    print(
        f"joshua: warning: {path}: motor '{motor}': range {low}..{high} {problem}; is it the arm's calibration?",
        file=sys.stderr,
    )


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


@dataclass(frozen=True)
class LeRobotUnits:
    """How LeRobot values of the SO-100 features are the model's joint values: the body joints' unit, the
    arm's calibration (motor name -> range; needed for RANGE, used for the gripper when given), and the
    mirror's offsets (model joint -> radians, sim = robot + offset; `joint_offsets`)."""

    body: BodyUnits = BodyUnits.DEGREES
    calibration: Mapping[str, MotorRange] | None = None
    offsets: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.body is BodyUnits.RANGE and self.calibration is None:
            raise UsageError(
                "LeRobot's range units (use_degrees=False: -100..100 over each joint's calibrated range) need the "
                "arm's calibration: give the JSON lerobot-calibrate wrote (--calibration FILE)"
            )

    def to_model(self, name: str, values: NDArray[np.float64], joint_range: tuple[float, float]) -> NDArray[np.float64]:
        """LeRobot values of feature `name` in the model joint's units."""
        if name not in SO100_JOINTS:
            return values
        low, high = _finite(name, joint_range)
        mid, motor = (low + high) / 2, self._motor(name)
        if name == GRIPPER:
            share = (GRIPPER_SCALE - values if motor and motor.drive_mode else values) / GRIPPER_SCALE
            robot = low + share * (high - low) if motor is None else mid + (2 * share - 1) * motor.half_span
        elif self.body is BodyUnits.DEGREES:
            robot = mid + np.radians(values)
        else:
            assert motor is not None
            robot = mid + (-values if motor.drive_mode else values) / RANGE_SCALE * motor.half_span
        return robot + self._offset(name)

    def from_model(
        self, name: str, values: NDArray[np.float64], joint_range: tuple[float, float]
    ) -> NDArray[np.float64]:
        """Model joint values in the units of LeRobot feature `name` (the inverse of `to_model`)."""
        if name not in SO100_JOINTS:
            return values
        low, high = _finite(name, joint_range)
        mid, motor = (low + high) / 2, self._motor(name)
        robot = values - self._offset(name)
        if name == GRIPPER:
            share = (robot - low) / (high - low) if motor is None else ((robot - mid) / motor.half_span + 1) / 2
            percent = share * GRIPPER_SCALE
            return GRIPPER_SCALE - percent if motor and motor.drive_mode else percent
        if self.body is BodyUnits.DEGREES:
            return np.degrees(robot - mid)
        assert motor is not None
        scaled = (robot - mid) / motor.half_span * RANGE_SCALE
        return -scaled if motor.drive_mode else scaled

    def _offset(self, name: str) -> float:
        """The mirror's offset of feature `name`'s joint, of whichever arm's joint names the offsets use (the
        arms' joint names differ)."""
        return next((self.offsets[table[name]] for table in ARM_JOINTS.values() if table[name] in self.offsets), 0.0)

    def _motor(self, name: str) -> MotorRange | None:
        return None if self.calibration is None else self.calibration[name.removesuffix(POSITION_SUFFIX)]


DEFAULT_UNITS = LeRobotUnits()  # lerobot's default: use_degrees=True, no calibration, no offsets


def add_units_arguments(parser: argparse.ArgumentParser, *, what: str) -> None:
    """`--units degrees|range` and `--calibration JSON`, the one definition of LeRobot's unit options; `what`
    says whose values they describe (e.g. "the dataset's")."""
    parser.add_argument(
        "--units",
        choices=[str(units) for units in BodyUnits],
        default=str(BodyUnits.DEGREES),
        help=f"the unit of {what} SO-100 body joints: degrees (lerobot's use_degrees=True, the default) or range "
        "(use_degrees=False: -100..100 over the calibrated range; needs --calibration)",
    )
    parser.add_argument(
        "--calibration",
        type=Path,
        metavar="JSON",
        help="the arm's LeRobot calibration file (lerobot-calibrate): each motor's calibrated range",
    )


def units_from_arguments(args: argparse.Namespace) -> LeRobotUnits:
    """The `LeRobotUnits` of `add_units_arguments`' options; a range mode without calibration, or a calibration
    file that does not read, is a UsageError."""
    calibration = None if args.calibration is None else read_calibration(args.calibration)
    return LeRobotUnits(BodyUnits(args.units), calibration)


def units_metadata(units: LeRobotUnits) -> dict[str, Any]:
    """`units` as the dataset records them (info.json, the state and action features' `units`), so that the
    reader converts back without being told: body unit, calibrated ranges, offsets."""
    calibration = None
    if units.calibration is not None:
        calibration = {motor: vars(motor_range) for motor, motor_range in units.calibration.items()}
    return {"body": str(units.body), "calibration": calibration, "offsets": dict(units.offsets)}


def units_from_metadata(metadata: Any, where: str) -> LeRobotUnits:
    """The `LeRobotUnits` a dataset records (`units_metadata`); a malformed record is a TrajectoryError naming
    `where`."""
    try:
        calibration = metadata["calibration"]
        offsets = {str(joint): float(offset) for joint, offset in metadata["offsets"].items()}
        return LeRobotUnits(
            body=BodyUnits(metadata["body"]),
            calibration=None
            if calibration is None
            else {str(motor): MotorRange(**entry) for motor, entry in calibration.items()},
            offsets=offsets,
        )
    except (KeyError, TypeError, ValueError, AttributeError, UsageError) as error:
        raise TrajectoryError(f"{where} is not a units record of joshua's writer: {error}") from None


def joint_offsets(model: Any, mappings: Sequence[TopicMapping]) -> dict[str, float]:
    """The mirror's mapping (`simulation.mirror_topic_mappings`: actuator -> offset, sim = robot + offset) as
    model joint -> offset, each actuator resolved to the joint it drives in the compiled `model`; an actuator
    the model lacks or one driving no joint is a UsageError."""
    import mujoco

    offsets: dict[str, float] = {}
    for mapping in mappings:
        actuator = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, mapping.mujoco_actuator)
        if actuator < 0 or int(model.actuator_trntype[actuator]) != int(mujoco.mjtTrn.mjTRN_JOINT):
            raise UsageError(f"the mirror mapping's actuator '{mapping.mujoco_actuator}' drives no joint of the model")
        offsets[model.joint(int(model.actuator_trnid[actuator, 0])).name] = float(mapping.offset)
    return offsets


def _finite(name: str, joint_range: tuple[float, float]) -> tuple[float, float]:
    low, high = joint_range
    if not (math.isfinite(low) and math.isfinite(high) and high > low):
        raise TrajectoryError(f"'{name}' is relative to its joint's range, but the model's joint has none")
    return low, high
