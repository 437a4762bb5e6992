"""LeRobot's SO follower features on the SO-101 model, whose joints carry the motors' names: the features map to
them (not to the SO-ARM100's joint_1 .. joint_6), the robot type is so101_follower, degrees and the gripper's
0..100 convert about the middle of each range, and the mirror's offsets apply by the SO-101's joint names."""

from __future__ import annotations

import mujoco
import numpy as np

from joshua_core.resources import models_dir
from joshua_lerobot.joints import (
    SO100_JOINTS,
    SO101_JOINTS,
    SO101_ROBOT_TYPE,
    BodyUnits,
    LeRobotUnits,
    feature_names,
    model_joint,
)


def ranges(path: str) -> dict[str, tuple[float, float]]:
    model = mujoco.MjModel.from_xml_path(str(models_dir() / path))
    return {
        model.joint(j).name: tuple(model.jnt_range[j])
        for j in range(model.njnt)
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE
    }


def test_so101_features_name_its_joints_and_robot_type() -> None:
    so101, so100 = ranges("so101/so101.xml"), ranges("so_arm100/so_arm100.xml")
    assert feature_names(list(so101)) == (list(SO101_JOINTS), SO101_ROBOT_TYPE)
    for feature in SO100_JOINTS:
        assert model_joint(feature, so101) == SO101_JOINTS[feature]
        assert model_joint(feature, so100) == SO100_JOINTS[feature]


def test_so101_units_convert_about_the_middle_of_each_range_with_its_offsets() -> None:
    joints = ranges("so101/so101.xml")
    units = LeRobotUnits(BodyUnits.DEGREES, offsets={"elbow_flex": 0.1})
    assert units.to_model("shoulder_lift.pos", np.array([90.0]), joints["shoulder_lift"]) == np.pi / 2
    np.testing.assert_allclose(units.to_model("elbow_flex.pos", np.array([0.0]), joints["elbow_flex"]), 0.1)
    low, high = joints["gripper"]
    np.testing.assert_allclose(units.to_model("gripper.pos", np.array([0.0, 100.0]), (low, high)), [low, high])
    np.testing.assert_allclose(units.from_model("elbow_flex.pos", np.array([0.1]), joints["elbow_flex"]), 0.0)
