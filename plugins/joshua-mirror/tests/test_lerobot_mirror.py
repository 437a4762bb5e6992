"""The MIRROR mode on SO-101 arms read through the real lerobot 0.4.4 (`simulation.mirror.lerobot`), each arm a
serial-port fake (tests/feetech_bus.py: six STS3215 servos speaking Feetech protocol 0 on a pty) that lerobot's own
FeetechMotorsBus talks to. tests/lerobot_arm_side.py runs every scenario in one process with lerobot importable:
the twin of a follower moved by hand, a leader teleoperating the simulated arm into a LeRobot dataset that lerobot
then loads, and the refusals.

Expected values are computed here from ticks, independently of joshua-lerobot: every motor is calibrated over
1024..3072 (its middle is the model joint's middle), so the model angle is mid + (t - 2048) x 2 pi / 4095, LeRobot's
degrees (t - 2048) x 360 / 4095 and the gripper's percent (t - 1024) / 2048 x 100.
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest

from joshua_core.cli import main
from joshua_core.resources import models_dir

JOINTS = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper")  # servo ids 1..6
POSE_A = (2300, 1800, 2500, 1700, 2200, 1900)  # lerobot_arm_side.py's two poses, ticks of servos 1..6
POSE_B = (1800, 2250, 1750, 2400, 1900, 2350)
RANGE = (1024, 3072)
MIDDLE_TICK = 2048
# The twin's joint is the arm's angle through two unit conversions in float64: equal to rounding.
FOLLOW_TOLERANCE_RAD = 1e-6
# The dataset keeps float32: a value of tens of degrees to about 1e-5.
ACTION_TOLERANCE = 1e-3
# The simulated arm's position actuators hold against gravity with a steady error of a few degrees.
SETTLED_DEGREES = 5.0
# Between the poses each joint travels tens of degrees; a state that never lags its action by this much would be
# the leader's values copied, not the simulated arm's.
LAG_DEGREES = 10.0


@pytest.fixture(scope="module")
def side(lerobot_side: Callable[[str], dict[str, Any]]) -> dict[str, Any]:
    return dict(lerobot_side("mirror")["mirror"])


def model_radians(ticks: tuple[int, ...]) -> list[float]:
    arm = mujoco.MjModel.from_xml_path(str(models_dir() / "so101" / "scene.xml"))
    middles = [float(np.mean(arm.joint(joint).range)) for joint in JOINTS]
    return [mid + (t - MIDDLE_TICK) * 2 * math.pi / 4095 for mid, t in zip(middles, ticks, strict=True)]


def lerobot_values(ticks: tuple[int, ...]) -> list[float]:
    """What lerobot reads: degrees for the body joints, percent of the calibrated range for the gripper."""
    *body, gripper = ticks
    return [(t - MIDDLE_TICK) * 360 / 4095 for t in body] + [(gripper - RANGE[0]) / (RANGE[1] - RANGE[0]) * 100]


def test_the_twin_follows_a_follower_read_through_lerobot_and_writes_nothing_to_it(side: dict[str, Any]) -> None:
    run = side["follow"]
    assert run["status"] == 0 and not run["driver_failed"], run
    report = side["follow_report"]
    assert report["lerobot"] == "so101_follower" and report["stopped_by"] == "Ctrl-C" and report["unanswered"] == 0
    final = [report["joints"][joint]["final_qpos"] for joint in JOINTS]
    assert np.allclose(final, model_radians(POSE_B), atol=FOLLOW_TOLERANCE_RAD, rtol=0)
    rows = [row for row in csv.reader(io.StringIO(side["follow_csv"])) if row and not row[0].startswith("#")]
    header, first, last = rows[0], rows[1], rows[-1]
    assert header[1:] == list(JOINTS)
    assert np.allclose([float(v) for v in first[1:]], model_radians(POSE_A), atol=FOLLOW_TOLERANCE_RAD, rtol=0)
    assert np.allclose([float(v) for v in last[1:]], model_radians(POSE_B), atol=FOLLOW_TOLERANCE_RAD, rtol=0)
    # Read only: no goal written, and lerobot's configure (which turns the torque on) never ran.
    assert side["follow_goals"] == 0 and set(side["follow_torque"].values()) == {0}


def test_a_leader_teleoperates_the_simulated_arm_into_a_dataset_lerobot_loads(side: dict[str, Any]) -> None:
    run = side["teleop"]
    assert run["status"] == 0 and not run["driver_failed"], run
    assert side["teleop_report"]["lerobot"] == "so101_leader"
    dataset = side["dataset"]
    assert dataset["robot_type"] == "so101_follower"
    assert dataset["names"] == [f"{joint}.pos" for joint in JOINTS]
    assert dataset["cameras"] == ["observation.images.overview"]  # the model's first camera
    assert dataset["frames"] == len(dataset["action"]) == len(dataset["state"]) > 1
    actions, states = np.array(dataset["action"]), np.array(dataset["state"])
    a, b = np.array(lerobot_values(POSE_A)), np.array(lerobot_values(POSE_B))
    # The actions are the leader's values: its first pose, its second, and between them only where a frame falls
    # between two readings.
    assert np.allclose(actions[0], a, atol=ACTION_TOLERANCE, rtol=0)
    assert np.allclose(actions[-1], b, atol=ACTION_TOLERANCE, rtol=0)
    low, high = np.minimum(a, b) - ACTION_TOLERANCE, np.maximum(a, b) + ACTION_TOLERANCE
    assert ((actions >= low) & (actions <= high)).all()
    # The states are the simulated arm's: placed at the leader's first pose, lagging behind the move, then there.
    assert np.abs(states[0] - a).max() < SETTLED_DEGREES
    assert np.abs(states - actions).max() > LAG_DEGREES
    assert np.abs(states[-1] - b).max() < SETTLED_DEGREES


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("bad_port", "cannot open the arm's port"),
        ("no_calibration", "cannot read the LeRobot calibration"),
        ("silent", "does not answer"),
    ],
)
def test_a_bad_port_a_missing_calibration_or_a_silent_arm_is_one_line_and_exit_2(
    side: dict[str, Any], case: str, message: str
) -> None:
    result = side[case]
    assert result["status"] == 2
    errors = [line for line in result["lines"] if line]
    assert len(errors) == 1 and errors[0].startswith("joshua: error: ") and message in errors[0], errors


@pytest.mark.parametrize(
    ("sets", "message"),
    [
        (["robot_type=so101_leader"], "set simulation.mirror.apply=ACTUATOR"),
        (["robot_type=so100_follower"], "is another arm than the model's (so101_follower joints)"),
        (["robot_type=koch_follower"], "is no LeRobot SO-10x arm"),
    ],
)
def test_a_lerobot_arm_that_does_not_fit_the_config_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], sets: list[str], message: str
) -> None:
    """Checked before lerobot is imported or a port opened: these run without lerobot."""
    calibration = tmp_path / "arm.json"
    entries = {joint: {"id": i, "drive_mode": 0, "homing_offset": 0, "range_min": RANGE[0], "range_max": RANGE[1]}
               for i, joint in enumerate(JOINTS, 1)}  # fmt: skip
    calibration.write_text(json.dumps(entries))
    arm = [*sets, "port=/dev/ttyACM0", f"calibration={calibration}"]
    overrides = [arg for value in arm for arg in ("--set", f"simulation.mirror.lerobot.{value}")]
    status = main(["--preset", "so101_sim_mirror", "--set", f"simulation.output_dir={tmp_path}", *overrides])
    errors = [line for line in capsys.readouterr().err.splitlines() if line]
    assert status == 2
    assert len(errors) == 1 and errors[0].startswith("joshua: error: ") and message in errors[0], errors
