"""The one table between LeRobot's joint names and units and the model's, both ways.

SO-100/SO-101 (`so100_follower`) datasets name the arm's joints `shoulder_pan.pos` ... `wrist_roll.pos` in
degrees, 0 at the middle of the calibrated range, and the gripper `gripper.pos` on 0 (closed) .. 100 (open).
JOSHUA's SO-ARM100 (models/so_arm100/so_arm100.xml) has joint_1 .. joint_6 in radians, with the calibrated
ranges; so a LeRobot angle a maps to mid + radians(a), mid the middle of the model joint's range, and the
gripper g to low + g / 100 * (high - low). Directions are taken to agree (the model follows the SO-100
URDF's axes). Any other feature name `<joint>.pos` is a joint of the model in the model's own units.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from joshua_core.trajectory import MAX_MAGNITUDE, TrajectoryError

SO100_ROBOT_TYPE = "so100_follower"
SO100_JOINTS = {
    "shoulder_pan.pos": "joint_1",
    "shoulder_lift.pos": "joint_2",
    "elbow_flex.pos": "joint_3",
    "wrist_flex.pos": "joint_4",
    "wrist_roll.pos": "joint_5",
    "gripper.pos": "joint_6",
}
GRIPPER = "gripper.pos"
GRIPPER_SCALE = 100.0  # LeRobot's gripper: 0 .. 100 over the range
POSITION_SUFFIX = ".pos"
# Largest magnitude an SO-100 value (arm angle in degrees, gripper in percent) may have: ±1e4 degrees is
# 28 turns, beyond any joint's travel, so a larger value is a corrupt file, not a pose.
MAX_SO100_VALUE = 1e4


def feature_names(joint_names: Sequence[str]) -> tuple[list[str], str | None]:
    """LeRobot names for the model joints `joint_names`, and the robot type: SO-100's when the joints are
    exactly the SO-ARM100's six, else `<joint>.pos` each (and no robot type)."""
    by_joint = {joint: name for name, joint in SO100_JOINTS.items()}
    if sorted(joint_names) == sorted(by_joint):
        return [by_joint[joint] for joint in joint_names], SO100_ROBOT_TYPE
    return [joint + POSITION_SUFFIX for joint in joint_names], None


def model_joint(name: str, joints: Mapping[str, tuple[float, float]]) -> str:
    """The model joint a LeRobot feature name stands for; a name matching none is a TrajectoryError."""
    joint = SO100_JOINTS.get(name) or name.removesuffix(POSITION_SUFFIX)
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


def to_model(name: str, values: NDArray[np.float64], joint_range: tuple[float, float]) -> NDArray[np.float64]:
    """LeRobot values of feature `name` in the model joint's units."""
    if name not in SO100_JOINTS:
        return values
    low, high = _finite(name, joint_range)
    if name == GRIPPER:
        return low + values / GRIPPER_SCALE * (high - low)
    return (low + high) / 2 + np.radians(values)


def from_model(name: str, values: NDArray[np.float64], joint_range: tuple[float, float]) -> NDArray[np.float64]:
    """Model joint values in the units of LeRobot feature `name` (the inverse of `to_model`)."""
    if name not in SO100_JOINTS:
        return values
    low, high = _finite(name, joint_range)
    if name == GRIPPER:
        return (values - low) / (high - low) * GRIPPER_SCALE
    return np.degrees(values - (low + high) / 2)


def _finite(name: str, joint_range: tuple[float, float]) -> tuple[float, float]:
    low, high = joint_range
    if not (math.isfinite(low) and math.isfinite(high) and high > low):
        raise TrajectoryError(f"'{name}' is relative to its joint's range, but the model's joint has none")
    return low, high
