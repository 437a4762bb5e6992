"""`joshua deploy --lerobot` on an SO-100 arm that is a serial-port fake (tests/feetech_bus.py: six STS3215 servos
speaking Feetech protocol 0 on a pty), driven by the real lerobot 0.4.4 (its follower, FeetechMotorsBus, the
scservo SDK and pyserial; `./setup.sh --dev` installs them in .cache/lerobot-site). tests/lerobot_arm_side.py runs
every deploy scenario in one process with lerobot importable, once for the module; each test reads its part.

Ticks become model radians independently of joshua-lerobot here: every motor is calibrated over 1024..3072, whose
middle is the model's zero, and lerobot reads (ticks - middle) x 360 / 4095 degrees; so q = mid + (t - 2048) x
2 pi / 4095 for each joint (the gripper's 0..100 over the same span is the same angle).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
import pytest

from joshua_core.resources import models_dir

TARGET = (0.22, 0.05, 0.15)
# The shipped reach policy under the 4 rad/s speed limit settles within a few cm (docs/sim-to-real.md, Deploy); a
# unit, sign or joint-order error puts the gripper tens of cm away.
REACHED_M = 0.05
RANGE = (1024, 3072)  # every motor's calibrated range (lerobot_arm_side.py)
MIDDLE_TICK = 2048
GRIPPER = "joint_6"  # 0..100 over its calibrated range
RAD_PER_TICK = 2 * math.pi / 4095
TICK_TOLERANCE = 1  # lerobot rounds a goal to the nearest tick
JOINTS = ("joint_1", "joint_2", "joint_3", "joint_4", "joint_5", "joint_6")  # servo ids 1..6
MAX_SPEED_RAD_S, RATE_HZ = 4.0, 50.0  # joshua deploy's defaults and the policy's control rate


@pytest.fixture(scope="module")
def side(lerobot_side: Callable[[str], dict[str, Any]]) -> dict[str, Any]:
    return lerobot_side("deploy")


def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(models_dir() / "so_arm100" / "scene.xml"))


def radians(arm: mujoco.MjModel, joint: str, ticks: float) -> float:
    low, high = arm.joint(joint).range
    return (low + high) / 2 + (ticks - MIDDLE_TICK) * RAD_PER_TICK


def test_the_policy_reaches_the_target_through_lerobot_and_the_arm_holds_its_last_goal(side: dict[str, Any]) -> None:
    deploy = side["deploy"]
    run, report = deploy["run"], deploy["report"]
    assert run["status"] == 0 and not run["driver_failed"], run
    assert report["lerobot"] == "so100_follower" and report["stopped_by"] == "SIGTERM" and report["steps"] > 0
    arm = model()
    data = mujoco.MjData(arm)
    distances = []
    for ticks in deploy["path"]:  # the servos read after the arm answered again
        for servo, joint in enumerate(JOINTS, 1):
            data.qpos[arm.joint(joint).qposadr[0]] = radians(arm, joint, ticks[str(servo)])
        mujoco.mj_forward(arm, data)
        distances.append(float(np.linalg.norm(data.site("gripper").xpos - TARGET)))
    # The closest approach: a unit or sign error keeps the gripper tens of centimetres away, while on a loaded
    # machine late control steps can leave it circling the target when the e-stop comes.
    assert min(distances) < REACHED_M, f"the gripper came no closer than {min(distances):.3f} m to the target"
    # Left holding: torque on, each servo at its last goal (the stop in place: where it was measured).
    assert set(deploy["torque"].values()) == {1}
    for servo in deploy["ticks"]:
        assert abs(deploy["ticks"][servo] - deploy["goals"][servo]) <= TICK_TOLERANCE
    for joint, entry in report["joints"].items():  # the report's last targets (LeRobot's units) are the goals
        sent = entry["last_target_sent"]
        ticks = RANGE[0] + sent / 100 * (RANGE[1] - RANGE[0]) if joint == GRIPPER else MIDDLE_TICK + sent * 4095 / 360
        servo = str(JOINTS.index(joint) + 1)
        assert abs(ticks - deploy["goals"][servo]) <= TICK_TOLERANCE, joint


def test_goals_stay_within_the_joint_limits_and_the_speed_limit(side: dict[str, Any]) -> None:
    arm = model()
    writes = side["deploy"]["goal_writes"]
    assert len(writes) > 10
    step_ticks = MAX_SPEED_RAD_S / RATE_HZ / RAD_PER_TICK + TICK_TOLERANCE
    for before, after in zip(writes, writes[1:], strict=False):
        for servo, ticks in after.items():
            joint = JOINTS[int(servo) - 1]
            low, high = arm.joint(joint).range
            assert low - RAD_PER_TICK <= radians(arm, joint, ticks) <= high + RAD_PER_TICK, (joint, ticks)
            # A goal moves at most max speed x period from the one before (a stop in place may jump back to
            # where the servo is, which is closer still).
            assert abs(ticks - before[servo]) <= step_ticks or after == writes[-1], (joint, before[servo], ticks)


def test_an_arm_that_stops_answering_holds_then_resumes_and_the_estop_latches(side: dict[str, Any]) -> None:
    deploy = side["deploy"]
    lines = deploy["run"]["lines"]
    assert any("does not answer" in line and "the servos hold their last goal" in line for line in lines)
    assert deploy["goals_at_hold"] == deploy["goals_before_answering"]  # nothing was sent while it held
    assert any("answers again" in line for line in lines)
    assert deploy["goals_after_estop"] == deploy["goals_at_estop"]  # after the stop in place, nothing more
    assert deploy["report"]["estop"]["latched"] and deploy["report"]["holds"]["episodes"] >= 1
    assert deploy["report"]["unanswered"] >= 1


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("bad_port", "cannot open the arm's port"),
        ("no_calibration", "cannot read the LeRobot calibration"),
        ("other_calibration", "holds another calibration than"),
        ("silent", "does not answer"),
    ],
)
def test_a_bad_port_a_missing_calibration_or_a_silent_arm_is_one_line_and_exit_2(
    side: dict[str, Any], case: str, message: str
) -> None:
    result = side["deploy"][case]
    assert result["status"] == 2
    errors = [line for line in result["lines"] if line]
    assert len(errors) == 1 and errors[0].startswith("joshua: error: ") and message in errors[0], errors


def test_a_refused_arm_is_left_as_it_was(side: dict[str, Any]) -> None:
    """A silent arm was never touched; one calibrated otherwise keeps the torque lerobot's configure left on."""
    assert set(side["deploy"]["silent_torque"].values()) == {0}
    assert set(side["deploy"]["other_torque"].values()) == {1}
