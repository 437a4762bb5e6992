"""`joshua deploy` end to end: the real command drives a MuJoCo arm behind ROS 2 topics, over rclpy on loopback.

The robot (tests/sim_robot.py, its own process) steps the SO-ARM100 in real time, publishes its encoders and
applies the targets it receives; `joshua deploy` runs the committed reach policy (models/policies/so_arm100_reach,
written by models/policies/generate_reach_policy.py through `joshua export`) on those topics. The robot tells
how far its gripper is from the target; the deploy's report tells what the node did.
"""

from __future__ import annotations

import json
import math
import shutil
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

import mujoco
import pytest

from joshua_core.config import load_preset
from joshua_core.plugins import PluginHost
from joshua_core.resources import models_dir
from joshua_mirror.joints import topic_mappings

JOSHUA = Path(sys.executable).parent / "joshua"
POLICY = models_dir() / "policies" / "so_arm100_reach"
SIM_ROBOT = Path(__file__).with_name("sim_robot.py")
TARGET = (0.22, 0.05, 0.15)  # inside the task's target box
REACHED_M = 0.03
MAPPINGS = topic_mappings(load_preset("sim_mirror", PluginHost.discover().options()).message.simulation)
COMMANDS = "".join(
    f'    command_topics {{ key: "{m.mujoco_actuator}" value: "/command/{m.mujoco_actuator}" }}\n' for m in MAPPINGS
)
CONFIG = f'extends: "sim_mirror"\nsimulation {{\n  mirror {{\n{COMMANDS}  }}\n}}\n'
ESTOP = "/test/estop"
TARGET_TOPIC = "/test/target"
FAST = ["--status-period", "0.2", "--estop-topic", ESTOP]
TIMEOUT_S = 60.0
LIFETIME_S = 180.0  # the robot and deploy of a test end by themselves then: a test waiting for a line fails, not hangs
Process = subprocess.Popen[str]


def robot_plan() -> dict[str, Any]:
    joints = [
        {"joint": m.mujoco_actuator.removesuffix("_position"), "actuator": m.mujoco_actuator,
         "encoder": m.ros_topic, "command": f"/command/{m.mujoco_actuator}", "offset": m.offset}
        for m in MAPPINGS
    ]  # fmt: skip
    return {
        "model": str(models_dir() / "so_arm100" / "scene.xml"),
        "keyframe": "home",
        "rate": 100,
        "site": "gripper",
        "target": TARGET,
        "estop_topic": ESTOP,
        "target_topic": TARGET_TOPIC,
        "joints": joints,
        "lifetime": LIFETIME_S + 30,
    }


def start(command: list[str], env: dict[str, str], cwd: Path) -> subprocess.Popen[str]:
    return subprocess.Popen(command, cwd=cwd, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)  # fmt: skip


def next_line(stream: IO[str] | None, wanted: Callable[[str], bool], what: str, process: Process | None = None) -> str:
    """The stream's next line for which `wanted` is true (status lines come every 0.2 s, robot lines every 0.1 s)."""
    assert stream is not None
    while not wanted(line := stream.readline()):
        assert line, f"the process ended before {what}" + (f": {process.communicate()[1]}" if process else "")
    return line


def tell(robot: subprocess.Popen[str], word: str) -> None:
    assert robot.stdin is not None
    robot.stdin.write(word + "\n")
    robot.stdin.flush()


def robot_result(robot: subprocess.Popen[str], published: int | None = None) -> dict[str, Any]:
    """What the robot saw, once the `published` commands (the deploy's count) have all arrived: the last
    ones may still be on their way when the deploy has stopped."""
    if published is not None:
        tell(robot, f"await {published}")
        next_line(robot.stdout, lambda line: line.startswith("received "), "every published target", robot)
    tell(robot, "quit")
    line = next_line(robot.stdout, lambda line: line.startswith("result "), "its result", robot)
    robot.communicate(timeout=30)
    return json.loads(line.removeprefix("result "))


def stop_deploy(deploy: subprocess.Popen[str], cwd: Path, signum: int = signal.SIGINT) -> dict[str, Any]:
    deploy.send_signal(signum)
    out, err = deploy.communicate(timeout=30)
    assert deploy.returncode == 0 and "Traceback" not in err, err
    (report,) = (cwd / "joshua_output").glob("deploy_*/deploy_report.json")
    return json.loads(report.read_text())


@pytest.fixture
def robot_and_deploy(
    request: pytest.FixtureRequest, tmp_path: Path, ros_env: dict[str, str]
) -> Iterator[tuple[Process, Process]]:
    """The simulated robot and `joshua deploy` on its topics, both running; stopped after the test. An indirect
    parameter may give the deploy's target arguments ("target", else `--target`) and plan keys ("plan")."""
    (tmp_path / "arm.pbtxt").write_text(CONFIG)
    param = getattr(request, "param", {})
    plan = {**robot_plan(), **param.get("plan", {})}
    robot = start([sys.executable, str(SIM_ROBOT), json.dumps(plan)], ros_env, tmp_path)
    next_line(robot.stdout, lambda line: line == "ready\n", "ready")
    target = param.get("target", ["--target", ",".join(map(str, TARGET))])
    command = [
        str(JOSHUA),
        "deploy",
        str(POLICY),
        "--config",
        "arm.pbtxt",
        *target,
        *FAST,
        "--duration",
        str(LIFETIME_S),
    ]
    if "calibration" in param:
        (tmp_path / "arm.json").write_text(json.dumps(param["calibration"]))
    deploy = start([*command, *param.get("deploy", [])], ros_env, tmp_path)
    try:
        yield robot, deploy
    finally:
        for process in (robot, deploy):
            if process.poll() is None:
                process.kill()
                process.communicate()


def test_policy_reaches_the_target_and_holds_on_stale_encoders(
    tmp_path: Path, robot_and_deploy: tuple[Process, Process]
) -> None:
    robot, deploy = robot_and_deploy
    next_line(deploy.stderr, lambda line: "deploy: RUNNING" in line, "RUNNING")
    reached = next_line(robot.stdout, lambda line: float(line.split()[1]) < REACHED_M, "the target was reached")
    print(reached.strip())
    tell(robot, "mute")  # the encoders stop: the deploy must hold
    next_line(deploy.stderr, lambda line: "deploy: HOLD" in line, "HOLD")
    tell(robot, "mark")
    next_line(deploy.stderr, lambda line: line.startswith("[deploy") and " HOLD " in line, "a HOLD status line")
    next_line(deploy.stderr, lambda line: line.startswith("[deploy") and " HOLD " in line, "a second one")
    tell(robot, "mark")
    tell(robot, "unmute")
    next_line(deploy.stderr, lambda line: "deploy: RUNNING" in line, "RUNNING again")
    next_line(robot.stdout, lambda line: float(line.split()[1]) < REACHED_M, "the target was reached again")
    report = stop_deploy(deploy, tmp_path)  # it stops the arm in place: one more target per joint
    result = robot_result(robot, report["published_messages"])
    first, second = result["marks"]
    assert second - first <= 6, result  # at most a step already on its way while held (>= 0.2 s: 10 steps)
    assert result["commands"] > second  # and it resumed
    assert report["stopped_by"] == "SIGINT" and report["holds"]["episodes"] >= 1 and report["holds"]["seconds"] > 0.2
    assert report["published_messages"] == result["commands"] == 6 * (report["steps"] + 1)  # all delivered, counted
    assert report["rate_hz"] == 50 and report["latency_us"]["input_to_publish"]["samples"] == report["steps"]
    assert all(joint["received"] > 0 and joint["last_target_sent"] is not None for joint in report["joints"].values())


# An SO-100 calibrated by lerobot-calibrate: motor -> ticks range (drive mode set on the elbow)
LEROBOT_RANGES = {
    "shoulder_pan": (820, 3300), "shoulder_lift": (880, 3170), "elbow_flex": (880, 3100),
    "wrist_flex": (870, 3200), "wrist_roll": (0, 4095), "gripper": (2010, 3400),
}  # fmt: skip
CALIBRATION = {
    motor: {"id": i + 1, "drive_mode": int(motor == "elbow_flex"), "homing_offset": 0, "range_min": low,
            "range_max": high}
    for i, (motor, (low, high)) in enumerate(LEROBOT_RANGES.items())
}  # fmt: skip


def lerobot_range_units() -> list[tuple[float, float]]:
    """(k, c) per joint: lerobot's use_degrees=False value = k * angle + c, the angle from the middle of the
    calibrated range (the model's zero, its ranges symmetric) in radians at 2 pi / 4095 per tick: -100..100 over
    the range for the body (negated where the drive mode is set), 0..100 for the gripper."""
    model = mujoco.MjModel.from_xml_path(str(models_dir() / "so_arm100" / "scene.xml"))
    units = []
    for motor, (low, high) in LEROBOT_RANGES.items():
        half_span = (high - low) / 2 * 2 * math.pi / 4095
        if motor == "gripper":
            joint_low, joint_high = model.joint("joint_6").range
            units.append((50 / half_span, 50 - 50 / half_span * (joint_low + joint_high) / 2))
        else:
            units.append(((-100 if CALIBRATION[motor]["drive_mode"] else 100) / half_span, 0.0))
    return units


@pytest.mark.parametrize(
    "robot_and_deploy",
    [
        {
            "plan": {
                "joints": [j | {"units": u} for j, u in zip(robot_plan()["joints"], lerobot_range_units(), strict=True)]
            },
            "calibration": CALIBRATION,
            "deploy": ["--units", "range", "--calibration", "arm.json"],
        }
    ],
    indirect=True,
)
def test_an_arm_in_lerobots_range_units_reaches_the_target(
    tmp_path: Path, robot_and_deploy: tuple[Process, Process]
) -> None:
    robot, deploy = robot_and_deploy
    next_line(robot.stdout, lambda line: float(line.split()[1]) < REACHED_M, "the target was reached", deploy)
    report = stop_deploy(deploy, tmp_path)
    result = robot_result(robot, report["published_messages"])
    sent = [joint["last_target_sent"] for joint in report["joints"].values()]
    assert result["last_commands"] == pytest.approx(sent, abs=1e-9)  # what the robot got: LeRobot's units
    body = [abs(value) for value in result["last_commands"][:5]]
    assert max(body) <= 100 and max(body) > 3  # -100..100, not radians


def test_estop_stops_the_targets_until_restart(tmp_path: Path, robot_and_deploy: tuple[Process, Process]) -> None:
    robot, deploy = robot_and_deploy
    next_line(deploy.stderr, lambda line: "deploy: RUNNING" in line, "RUNNING")
    next_line(robot.stdout, lambda line: float(line.split()[1]) < 0.05, "the arm moving (from 6.3 cm)")
    tell(robot, "estop")
    next_line(deploy.stderr, lambda line: "deploy: E-STOP" in line, "E-STOP")
    for _ in range(3):  # 0.6 s more: 30 steps if it still ran
        next_line(deploy.stderr, lambda line: line.startswith("[deploy") and "E-STOP" in line, "E-STOP status")
    report = stop_deploy(deploy, tmp_path, signal.SIGTERM)
    result = robot_result(robot, report["published_messages"])
    # after the e-stop: at most a step already on its way, then one target per joint to stop in place, then nothing
    assert result["estop_sent_at"] > 0 and result["commands"] - result["estop_sent_at"] <= 12, result
    for command, encoder in zip(result["last_commands"], result["encoders"], strict=True):
        assert abs(command - encoder) < 0.05, result  # the arm was told to stay where it was, and stayed
    assert report["stopped_by"] == "SIGTERM" and report["estop"]["latched"]
    assert report["published_messages"] == result["commands"]


@pytest.mark.parametrize("robot_and_deploy", [{"plan": {"deaf": True}}], indirect=True)
def test_nothing_is_published_before_the_robot_subscribes(
    tmp_path: Path, robot_and_deploy: tuple[Process, Process]
) -> None:
    robot, deploy = robot_and_deploy  # its encoders come, but it does not listen to the command topics yet
    next_line(deploy.stderr, lambda line: "WAITING no subscriber yet on /command/" in line, "waiting for a listener")
    next_line(deploy.stderr, lambda line: "WAITING no subscriber yet on /command/" in line, "a second status line")
    tell(robot, "mark")  # every target published so far would have been lost
    tell(robot, "listen")
    next_line(deploy.stderr, lambda line: "deploy: RUNNING" in line, "RUNNING")
    next_line(robot.stdout, lambda line: float(line.split()[1]) < REACHED_M, "the target was reached")
    report = stop_deploy(deploy, tmp_path)
    result = robot_result(robot, report["published_messages"])
    assert result["marks"] == [0] and report["published_messages"] == result["commands"] > 0, (report, result)


@pytest.mark.parametrize("robot_and_deploy", [{"target": ["--target-topic", TARGET_TOPIC]}], indirect=True)
def test_the_target_comes_from_a_point_topic(tmp_path: Path, robot_and_deploy: tuple[Process, Process]) -> None:
    robot, deploy = robot_and_deploy
    next_line(deploy.stderr, lambda line: "WAITING" in line and "no target yet" in line, "waiting for a target")
    tell(robot, "target 0.25 -0.08 0.12")
    next_line(deploy.stderr, lambda line: "deploy: RUNNING" in line, "RUNNING")
    next_line(robot.stdout, lambda line: float(line.split()[1]) < REACHED_M, "the new target was reached")
    report = stop_deploy(deploy, tmp_path)
    robot_result(robot)
    assert report["target"] == [0.25, -0.08, 0.12] and report["targets_received"] == 1


def test_a_topic_of_another_type_stops_the_deploy(
    tmp_path: Path, ros_env: dict[str, str], hold_publishers: Callable[..., subprocess.Popen[str]]
) -> None:
    (tmp_path / "arm.pbtxt").write_text(CONFIG)
    hold_publishers(ros_env, [{"topic": "/encoder/joint_2", "type": "Float32", "value": 0.1}])
    result = subprocess.run(
        [str(JOSHUA), "deploy", str(POLICY), "--config", "arm.pbtxt", "--target", "0.2,0,0.1", *FAST,
         "--duration", str(TIMEOUT_S)],
        cwd=tmp_path, env=ros_env, capture_output=True, text=True, timeout=TIMEOUT_S + 30,
    )  # fmt: skip
    assert result.returncode == 2 and "Traceback" not in result.stderr
    last = result.stderr.strip().splitlines()[-1]
    assert last.startswith(
        "joshua: error: deploy: wrong message type: /encoder/joint_2 is published as std_msgs/msg/Float32"
    )
    assert last.endswith("but the deploy reads std_msgs/msg/Float64: those messages never arrive")
    (report,) = (tmp_path / "joshua_output").glob("deploy_*/deploy_report.json")
    assert json.loads(report.read_text())["stopped_by"] == "wrong message type"


@pytest.mark.slow
def test_bad_input_is_one_line(tmp_path: Path, ros_env: dict[str, str]) -> None:
    (tmp_path / "arm.pbtxt").write_text(CONFIG)
    five = "".join(  # a config of its own: joint_6 is not mapped
        f'    mappings {{ ros_topic: "{m.ros_topic}" mujoco_actuator: "{m.mujoco_actuator}" }}\n' for m in MAPPINGS[:5]
    )
    commands = "".join(line for line in COMMANDS.splitlines(True) if MAPPINGS[5].mujoco_actuator not in line)
    (tmp_path / "five.pbtxt").write_text(
        'operation_mode: SIMULATION\nsimulation {\n  mode: MIRROR\n  model_path: "so_arm100/scene.xml"\n'
        f"  mirror_topic_mappings {{\n{five}  }}\n  mirror {{\n{commands}"
        "  }\n}\n"
    )
    corrupt, foreign, texted = tmp_path / "corrupt", tmp_path / "foreign", tmp_path / "texted"
    for folder in (corrupt, foreign, texted):
        shutil.copytree(POLICY, folder)
    (corrupt / "policy.onnx").write_bytes(b"not a graph")
    (texted / "policy.json").write_text(
        json.dumps(json.loads((texted / "policy.json").read_text()) | {"control_hz": "50"})
    )
    contract = json.loads((foreign / "policy.json").read_text())
    contract["robot"]["sha256"] = "0" * 64
    (foreign / "policy.json").write_text(json.dumps(contract))
    cases = [
        ([str(tmp_path / "nowhere")], "holds no exported policy: no policy.json"),
        ([str(corrupt)], "policy.onnx is missing or is not the file"),
        ([str(foreign)], "is not the one the policy was trained on"),
        ([str(texted)], "policy.json: control_hz is '50'; expected a number of Hz from 1 to 10000"),
        ([str(POLICY), "--preset", "sim_mirror"], "command topic (simulation.mirror.command_topics): joint_1_position"),
        ([str(POLICY), "--config", "five.pbtxt"], "observes joints that the mirror config does not map: joint_6"),
        ([str(POLICY), "--config", "arm.pbtxt", "--target", "1,2"], "--target takes three numbers X,Y,Z in metres"),
        (
            [str(POLICY), "--config", "arm.pbtxt", "--target", "0.2,0,0.1", "--rate", "0"],
            "--rate takes a number at least 1",
        ),
        ([str(POLICY), "--run-name", "../../x"], "--run-name '../../x' holds a '/'"),
        ([str(POLICY), "--run-name", "x_step_7"], "ends in _step_<N>"),
        ([str(POLICY), "--units", "range"], "need the arm's calibration: give the JSON lerobot-calibrate wrote"),
        ([str(POLICY), "--calibration", "arm.pbtxt"], "--calibration is for LeRobot's units"),
    ]
    for args, message in cases:
        if "--target" not in args:
            args = [*args, "--target", "0.2,0,0.1"]
        if "--preset" not in args and "--config" not in args:
            args = [*args, "--config", "arm.pbtxt"]
        result = subprocess.run([str(JOSHUA), "deploy", *args], cwd=tmp_path, env=ros_env, capture_output=True,
                                text=True, timeout=TIMEOUT_S)  # fmt: skip
        lines = result.stderr.strip().splitlines()
        assert result.returncode == 2 and len(lines) == 1 and message in lines[0], (args, result.stderr)
