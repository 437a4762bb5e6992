"""The MIRROR mode end to end: real `joshua` processes, real rclpy publishers, DDS on loopback only.

Each test starts `joshua` (the mirror, stopped with Ctrl-C = SIGINT once the publisher is done, or by
its duration) and a publisher process (tests/publisher.py or `joshua mirror-replay`), then reads
the mirror's JSON report. Traffic stays on this machine (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST)
in a random ROS domain per test run, so parallel runs do not see each other.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from joshua_core.config import load_preset
from joshua_core.errors import PluginNotFoundError
from joshua_core.plugins import PluginHost, PluginInfo
from joshua_core.resources import models_dir
from joshua_core.trajectory import Trajectory, read_trajectory, write_trajectory
from joshua_core.trajectory_sources import load_trajectory
from joshua_mirror.joints import topic_mappings

JOSHUA = Path(sys.executable).parent / "joshua"
PUBLISHER = Path(__file__).with_name("publisher.py")
OFFSETS = {
    m.mujoco_actuator.removesuffix("_position"): m.offset
    for m in topic_mappings(load_preset("sim_mirror", PluginHost.discover().options()).message.simulation)
}
JOINTS = [f"joint_{i}" for i in range(1, 7)]
FAST = ["--set", "simulation.mirror.display=NONE", "--set", "simulation.mirror.status_period=0.2"]


def start_mirror(tmp_path: Path, env: dict[str, str], *overrides: str) -> subprocess.Popen[str]:
    sets = [arg for override in overrides for arg in ("--set", override)]
    command = [str(JOSHUA), "--preset", "sim_mirror", *FAST, *sets]
    return subprocess.Popen(command, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def publish(env: dict[str, str], plan: dict[str, Any]) -> None:
    result = subprocess.run(
        [sys.executable, str(PUBLISHER), json.dumps(plan)], env=env, capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0, result.stderr


def stop(mirror: subprocess.Popen[str], tmp_path: Path) -> tuple[dict[str, Any], str]:
    """Ctrl-C the mirror; it must stop cleanly (exit 0) and leave its report."""
    mirror.send_signal(signal.SIGINT)
    out, err = mirror.communicate(timeout=30)
    assert mirror.returncode == 0, err
    assert "Traceback" not in err
    report = json.loads((tmp_path / "joshua_output" / "mirror_report.json").read_text())
    assert report["stopped_by"] == "Ctrl-C"
    return report, err


def motion(step: int) -> dict[str, float]:
    """A known motion of the six joints (encoder values, inside every joint range after the offset)."""
    return {
        joint: 0.4 * math.sin(0.3 * step + index) + (0.6 if joint == "joint_6" else 0.1)
        for index, joint in enumerate(JOINTS)
    }


def float64_plan(steps: range, topics: dict[str, str] | None = None) -> dict[str, Any]:
    messages = [
        {"topic": f"/encoder/{joint}", "value": value} for step in steps for joint, value in motion(step).items()
    ]
    return {"wait_for": "/encoder/joint_1", "messages": messages}


def assert_mirrored(report: dict[str, Any], values: dict[str, float]) -> None:
    """qpos == encoder value + offset (the offset is the config's float32, widened) within 1e-6."""
    for joint, value in values.items():
        entry = report["joints"][joint]
        assert entry["last_value"] == value
        assert abs(entry["final_qpos"] - (value + OFFSETS[joint])) < 1e-6, joint


def test_sim_mirror_preset_runs_for_its_duration(tmp_path: Path, ros_env: dict[str, str]) -> None:
    result = subprocess.run(
        [str(JOSHUA), "--preset", "sim_mirror", "--set", "simulation.duration=1", *FAST],
        cwd=tmp_path,
        env=ros_env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 0, result.stderr
    report = json.loads((tmp_path / "joshua_output" / "mirror_report.json").read_text())
    assert report["stopped_by"] == "duration" and 1.0 <= report["wall_seconds"] < 3.0
    assert all(entry["stale"] and entry["received"] == 0 for entry in report["joints"].values())
    assert "stale, no valid value for 0.5 s: joint_1 (/encoder/joint_1)" in result.stderr
    assert "[mirror" in result.stderr  # status lines


def test_float64_motion_is_mirrored_exactly(tmp_path: Path, ros_env: dict[str, str]) -> None:
    mirror = start_mirror(tmp_path, ros_env)
    publish(ros_env, float64_plan(range(40)))
    report, err = stop(mirror, tmp_path)
    assert_mirrored(report, motion(39))
    for entry in report["joints"].values():
        assert entry["accepted"] == 40 and entry["received"] == 40
        assert entry["final_ctrl"] == 0.0  # KINEMATIC: the actuators are not touched
        assert entry["tracking_error"] is None
    assert report["apply_latency_us"]["samples"] == 240
    assert report["lost_messages"] == {f"/encoder/{joint}": 0 for joint in JOINTS}  # a steady publisher loses none
    assert "lost" not in err.replace("0 messages lost", "")


def test_joint_state_motion_is_mirrored_exactly(tmp_path: Path, ros_env: dict[str, str]) -> None:
    mirror = start_mirror(tmp_path, ros_env, "simulation.mirror.message_type=JOINT_STATE")
    messages = []
    for step in range(30):
        values = motion(step)
        names = [*reversed(JOINTS), "gripper_camera_tilt"]  # any order; an unknown name is counted, not applied
        messages.append({"topic": "/joint_states", "names": names, "positions": [*(values[n] for n in names[:6]), 9.0]})
    messages.append({"topic": "/joint_states", "names": ["joint_1", "joint_2"], "positions": [0.1]})  # malformed
    publish(ros_env, {"wait_for": "/joint_states", "messages": messages})
    report, _ = stop(mirror, tmp_path)
    assert_mirrored(report, motion(29))
    assert all(entry["accepted"] == 30 for entry in report["joints"].values())
    assert report["unknown"] == {"gripper_camera_tilt": 30}
    assert report["malformed_messages"] == 1
    assert report["lost_messages"] == {"/joint_states": 0}


def test_bad_messages_are_counted_and_never_written(tmp_path: Path, ros_env: dict[str, str]) -> None:
    mirror = start_mirror(tmp_path, ros_env, "simulation.mirror.stale_timeout=0.3")
    good = 0.25
    bad = ["nan", "inf", "-inf", 5.0, -2.0]  # 5.0 and -2.0 (+ offset) lie outside joint_1's range of +-1.92
    messages = [{"topic": "/encoder/joint_1", "value": good}, *({"topic": "/encoder/joint_1", "value": v} for v in bad)]
    messages += [{"topic": "/encoder/joint_2", "value": 0.3}]
    for _ in range(30):  # a topic next to the mapped ones that no mapping names
        messages += [{"topic": "/encoder/joint_7", "value": 1.0}, {"sleep": 0.05}]
    publish(ros_env, {"wait_for": "/encoder/joint_1", "messages": messages})
    report, err = stop(mirror, tmp_path)
    joint_1 = report["joints"]["joint_1"]
    assert joint_1["received"] == 6 and joint_1["accepted"] == 1
    assert joint_1["rejected_non_finite"] == 3 and joint_1["rejected_out_of_range"] == 2
    assert joint_1["last_rejected_value"] == -2.0
    assert_mirrored(report, {"joint_1": good, "joint_2": 0.3})
    assert report["unknown"]["/encoder/joint_7"] > 0
    joint_3 = report["joints"]["joint_3"]  # never published: stale, left where it was
    assert joint_3["stale"] and joint_3["received"] == 0 and joint_3["final_qpos"] == 0.0
    assert report["joints"]["joint_1"]["stale"]  # 1.5 s passed since its last good value
    assert "rejected 5" in err  # the status line


def test_publisher_loss_and_return_resumes_mirroring(tmp_path: Path, ros_env: dict[str, str]) -> None:
    mirror = start_mirror(tmp_path, ros_env, "simulation.mirror.stale_timeout=0.3")
    wait_until_all_stale(mirror)  # no publisher yet
    publish(ros_env, float64_plan(range(10)))
    wait_until_all_stale(mirror)  # the publisher is gone
    publish(ros_env, float64_plan(range(100, 110)))  # a new publisher process
    report, _ = stop(mirror, tmp_path)
    assert_mirrored(report, motion(109))
    for entry in report["joints"].values():
        assert entry["accepted"] == 20
        assert entry["stale_episodes"] >= 2  # before the first publisher, and between the two
    assert not any(report["lost_messages"].values())  # the second publisher numbers its messages from 1 again


def test_two_publishers_on_one_topic_are_counted_apart(tmp_path: Path, ros_env: dict[str, str]) -> None:
    """Two publishers at once on each topic, each numbering its own messages: the interleaved numbers are no loss.

    A gap taken for a loss would count more messages than were sent (80 per topic). Fewer may be counted: the
    mirror reads best effort, and a publisher sees only its own side match, so a message it sends before the
    mirror's reader has matched it is dropped unseen (once in a CI run: 79 of joint_1's 80), and the mirror's
    numbering of that publisher starts at the first message it read. Both publishers are read on joint_1, so
    more than one publisher's 40 arrive there."""
    mirror = start_mirror(tmp_path, ros_env)
    plan = json.dumps(float64_plan(range(40)))
    publishers = [subprocess.Popen([sys.executable, str(PUBLISHER), plan], env=ros_env) for _ in range(2)]
    assert [publisher.wait(timeout=60) for publisher in publishers] == [0, 0]
    report, _ = stop(mirror, tmp_path)
    lost = report["lost_messages"]
    assert 40 < report["joints"]["joint_1"]["received"] + lost["/encoder/joint_1"] <= 80, (report["joints"], lost)
    assert all(entry["received"] + lost[entry["source"]] <= 80 for entry in report["joints"].values()), lost


def test_a_flood_the_mirror_cannot_read_is_reported_as_lost(tmp_path: Path, ros_env: dict[str, str]) -> None:
    """A burst of 5000 messages while the mirror process is stopped (SIGSTOP) overflows what DDS buffers and the
    subscription's keep-last queue of 100 hold. The publisher numbers its messages, so the mirror counts exactly
    the ones it never read (sent = received + lost), says so on stderr, in the status line and in the report.

    No timing is assumed: the mirror has read the first message before it is stopped (a publisher's first
    message seen starts its numbering), and the tail, five out-of-range values sent once the mirror has said
    the loss, is waited for in the status line ("rejected 5"), so every message that was not lost was read.
    The mirror reads best effort, so a message sent before its reader has matched the publisher is dropped
    unseen (the publisher sees only its own side match): the first message is sent again when the mirror's
    next STATUS_LINES status lines still show no reading. The numbering starts at whichever of those copies the
    mirror saw first, and a copy it read late (a loaded machine) counts too: the count is exact within them."""
    topic = "/encoder/joint_1"
    burst = [0.1 + index * 1e-5 for index in range(5000)]
    tail = [5.0] * 5  # outside joint_1's range: rejected, which the status line counts
    messages = [{"topic": topic, "value": 0.05, "until_read": "first sent"}, {"topic": topic, "burst": burst}]
    messages += [{"await": "burst sent"}, *({"topic": topic, "value": value} for value in tail)]
    mirror = start_mirror(tmp_path, ros_env)
    publisher = subprocess.Popen(
        [sys.executable, str(PUBLISHER), json.dumps({"wait_for": topic, "messages": messages})],
        env=ros_env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert publisher.stdin is not None and publisher.stdout is not None
    firsts = 1  # copies of the first message sent
    try:
        assert publisher.stdout.readline() == "first sent\n"
        while not joint_1_read(mirror):
            publisher.stdin.write("again\n")
            publisher.stdin.flush()
            assert publisher.stdout.readline() == "first sent\n"
            firsts += 1
        mirror.send_signal(signal.SIGSTOP)
        try:
            publisher.stdin.write("\n")
            publisher.stdin.flush()
            assert publisher.stdout.readline() == "burst sent\n"
        finally:
            mirror.send_signal(signal.SIGCONT)
        warning = wait_for_line(mirror, lambda line: line.startswith("joshua: mirror: lost "))
        publisher.stdin.write("\n")
        publisher.stdin.flush()
        assert publisher.wait(timeout=60) == 0
    finally:
        publisher.kill()
    status = wait_for_line(mirror, lambda line: line.startswith("[mirror") and "rejected 5" in joint_1_status(line))
    mirror.send_signal(signal.SIGINT)
    summary, err = mirror.communicate(timeout=30)
    assert mirror.returncode == 0 and "Traceback" not in err, err
    report = json.loads((tmp_path / "joshua_output" / "mirror_report.json").read_text())
    lost = report["lost_messages"][topic]
    received = report["joints"]["joint_1"]["received"]
    counted = received + lost  # every message from the first one the mirror saw
    assert lost > 0 and 1 <= counted - len(burst) - len(tail) <= firsts, (received, lost, firsts)
    assert f"{topic} " in warning and status.rstrip().endswith(f"| lost {lost}")
    assert f"{lost} messages lost" in summary
    assert not any(count for name, count in report["lost_messages"].items() if name != topic)
    assert report["joints"]["joint_1"]["last_value"] in burst  # the burst's newest messages were kept


STATUS_LINES = 15  # 3 s at FAST's status period: a message the mirror's reader received is read in milliseconds


def joint_1_read(mirror: subprocess.Popen[str]) -> bool:
    """Whether one of the mirror's next STATUS_LINES status lines shows a reading of joint_1."""
    for _ in range(STATUS_LINES):
        line = wait_for_line(mirror, lambda line: line.startswith("[mirror"))
        if joint_1_status(line).split()[2] != "never":
            return True
    return False


def joint_1_status(line: str) -> str:
    """joint_1's part of a status line: 'joint_1 RATE/s AGE [STALE] [rejected N]'."""
    return line.split("] ", 1)[1].split(" | ")[0]


def test_actuator_tracking_reports_sim_vs_real_error(tmp_path: Path, ros_env: dict[str, str]) -> None:
    mirror = start_mirror(tmp_path, ros_env, "simulation.mirror.apply=ACTUATOR")
    hold = [{"topic": f"/encoder/{joint}", "value": value} for joint, value in motion(0).items()]
    messages = []
    for _ in range(50):  # hold one pose for ~1 s: the servos reach it up to their sag under gravity
        messages += [*hold, {"sleep": 0.02}]
    publish(ros_env, {"wait_for": "/encoder/joint_1", "messages": messages})
    report, _ = stop(mirror, tmp_path)
    assert report["apply"] == "ACTUATOR" and report["physics_steps"] > 500
    for joint, value in motion(0).items():
        entry = report["joints"][joint]
        assert abs(entry["final_ctrl"] - (value + OFFSETS[joint])) < 1e-12
        error = entry["tracking_error"]
        assert error["samples"] == 49 and 0 <= error["rms"] <= error["max_abs"]
        # followed by physics, not written: within the servo's sag under gravity (and its friction dead band)
        assert 0 < abs(entry["final_qpos"] - entry["final_ctrl"]) < 0.25, joint
    # The twin starts at each joint's first value, so no start-up jump from qpos 0 counts: the pan
    # joint (vertical axis, no gravity load) holds its pose almost exactly.
    assert report["joints"]["joint_1"]["tracking_error"]["max_abs"] < 0.01


def test_float64_topics_published_with_another_type_are_reported(
    tmp_path: Path, ros_env: dict[str, str], hold_publishers: Callable[..., subprocess.Popen[str]]
) -> None:
    """Float32, String or JointState on a topic mapped as Float64: seen in the graph, said, exit 2 at the end."""
    mirror = start_mirror(tmp_path, ros_env)
    wait_for_line(mirror, lambda line: line.startswith("[mirror"))  # running: the publishers come later
    wrong = {"/encoder/joint_1": "std_msgs/msg/Float32", "/encoder/joint_2": "std_msgs/msg/String"}
    publisher_node = "/joshua_mirror_test_publisher"
    hold_publishers(
        ros_env,
        [
            {"topic": "/encoder/joint_1", "type": "Float32", "value": 0.1},
            {"topic": "/encoder/joint_2", "type": "String", "value": 0.1},
            {"topic": "/encoder/joint_3", "names": ["joint_3"], "positions": [0.1]},
        ],
    )
    wrong["/encoder/joint_3"] = "sensor_msgs/msg/JointState"
    unsaid = {f"type: {topic} is published as {kind} by {publisher_node}," for topic, kind in wrong.items()}
    while unsaid:  # in any order: each publisher is discovered on its own, its node's name maybe later
        line = wait_for_line(mirror, lambda line: "wrong message type" in line)
        unsaid -= {warning for warning in unsaid if warning in line}
    status = wait_for_line(mirror, lambda line: line.startswith("[mirror"))
    assert all(f"WRONG TYPE {topic}: {kind}" in status for topic, kind in wrong.items())
    mirror.send_signal(signal.SIGINT)
    _, err = mirror.communicate(timeout=30)
    assert mirror.returncode == 2 and "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert last.startswith("joshua: error: mirror: wrong message type: /encoder/joint_1 is published as")
    report = json.loads((tmp_path / "joshua_output" / "mirror_report.json").read_text())
    assert {topic: entry["published_as"] for topic, entry in report["type_mismatches"].items()} == {
        topic: [kind] for topic, kind in wrong.items()
    }
    assert all(entry["publishers"] == [publisher_node] for entry in report["type_mismatches"].values())


def test_joint_state_topic_of_another_type_fails_a_bounded_run(
    tmp_path: Path, ros_env: dict[str, str], hold_publishers: Callable[..., subprocess.Popen[str]]
) -> None:
    hold_publishers(ros_env, [{"topic": "/joint_states", "value": 0.1}])  # Float64
    result = subprocess.run(
        [str(JOSHUA), "--preset", "sim_mirror", *FAST, "--set", "simulation.mirror.message_type=JOINT_STATE"]
        + ["--set", "simulation.duration=5"],
        cwd=tmp_path,
        env=ros_env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2 and "Traceback" not in result.stderr
    last = result.stderr.strip().splitlines()[-1]  # the publisher's node name may not be known yet
    assert last.startswith("joshua: error: mirror: wrong message type: /joint_states is published as std_msgs/msg/")
    assert "as std_msgs/msg/Float64 by" in last or "as std_msgs/msg/Float64, but" in last
    assert last.endswith(", but the mirror reads sensor_msgs/msg/JointState: those messages never arrive")
    report = json.loads((tmp_path / "joshua_output" / "mirror_report.json").read_text())
    assert report["stopped_by"] == "duration" and list(report["type_mismatches"]) == ["/joint_states"]


def test_replay_tool_drives_the_mirror_end_to_end(tmp_path: Path, ros_env: dict[str, str]) -> None:
    rows = [(0.02 * i, *motion(i).values()) for i in range(26)]
    csv = tmp_path / "motion.csv"
    csv.write_text(
        "# a test motion\ntimestamp,"
        + ",".join(JOINTS)
        + "\n"
        + "".join(",".join(f"{v:.6f}" for v in row) + "\n" for row in rows)
    )
    mirror = start_mirror(tmp_path, ros_env)
    replay = subprocess.run(
        [str(JOSHUA), "mirror-replay", str(csv), "--preset", "sim_mirror", "--rate", "50"],
        cwd=tmp_path,
        env=ros_env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert replay.returncode == 0, replay.stderr
    report, _ = stop(mirror, tmp_path)
    for joint, expected in zip(JOINTS, (float(f"{v:.6f}") for v in rows[-1][1:]), strict=True):
        assert abs(report["joints"][joint]["final_qpos"] - expected) < 1e-6  # offsets inverted by the replay
        assert report["joints"][joint]["accepted"] == 26


def test_mapping_errors_list_the_model_actuators(tmp_path: Path, ros_env: dict[str, str]) -> None:
    result = subprocess.run(
        [
            str(JOSHUA),
            "--preset",
            "sim_mirror",
            *FAST,
            "--set",
            "simulation.mirror_topic_mappings.mappings[0].mujoco_actuator=joint_1_pos",
            "--set",
            "simulation.mirror_topic_mappings.mappings[2].mujoco_actuator=joint_2_position",
        ],
        cwd=tmp_path,
        env=ros_env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "mappings[0]: no actuator 'joint_1_pos' in the model. Did you mean: joint_1_position" in result.stderr
    assert "Actuators: joint_1_position, joint_2_position, joint_3_position" in result.stderr
    assert "actuator 'joint_2_position' is mapped 2 times" in result.stderr


def test_without_the_plugin_the_cli_says_what_to_install(tmp_path: Path) -> None:
    from joshua_core import builtin_plugin
    from joshua_mujoco import plugin as mujoco_plugin

    host = PluginHost(
        [
            (PluginInfo("core", "joshua-core", "0", "core"), builtin_plugin),
            (PluginInfo("mujoco", "joshua-mujoco", "0", "mujoco"), mujoco_plugin),
        ]
    )
    with pytest.raises(PluginNotFoundError, match=r"no mode named 'MIRROR' is installed.*pip install joshua-mirror"):
        host.mode("MIRROR")
    result = subprocess.run(
        [str(JOSHUA), "--preset", "sim_mirror"],
        cwd=tmp_path,
        env={**os.environ, "JOSHUA_DISABLE_PLUGINS": "joshua-mirror"},
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2 and "joshua-mirror, which is disabled" in result.stderr


def test_replay_reports_bad_csv_rows_and_missing_columns(tmp_path: Path, ros_env: dict[str, str]) -> None:
    bad_row = tmp_path / "bad.csv"
    bad_row.write_text("# comment\ntimestamp," + ",".join(JOINTS) + "\n0.0,0,0,0,0,0,0\n0.1,0,0,x,0,0,0\n")
    reversed_time = tmp_path / "reversed.csv"
    reversed_time.write_text("timestamp," + ",".join(JOINTS) + "\n0.1,0,0,0,0,0,0\n0.0,0,0,0,0,0,0\n")
    missing = tmp_path / "missing.csv"
    missing.write_text("timestamp,joint_1,joint_2,joint_3,joint_4,joint_5,joint6\n0.0,0,0,0,0,0,0\n")
    for csv, message in (
        (bad_row, f"{bad_row}:4: column 'joint_3' has 'x', which is not a number"),
        (reversed_time, f"{reversed_time}:3: timestamp 0 does not increase (previous 0.1)"),
        (missing, f"{missing}:1: column 'joint6' (did you mean: joint_6, joint_5?) is not a joint of the model"),
    ):
        result = subprocess.run(
            [str(JOSHUA), "mirror-replay", str(csv)], cwd=tmp_path, env=ros_env, capture_output=True, text=True
        )
        assert result.returncode == 2 and message in result.stderr and "Traceback" not in result.stderr


def test_headless_display_records_the_mirrored_motion(tmp_path: Path, ros_env: dict[str, str]) -> None:
    """With no display, the mirror records what it shows to an MP4.

    No timing is assumed: "display: recording to" comes after the first frame (the start pose) is recorded, and
    the status line's frame count tells when a frame was recorded after every joint's values were applied.
    """
    import cv2

    small = ("simulation.mirror.display=RECORD", "simulation.render_width=160", "simulation.render_height=120")
    mirror = start_mirror(tmp_path, {k: v for k, v in ros_env.items() if k != "DISPLAY"}, *small)
    assert mirror.stderr is not None
    wait_for_line(mirror, lambda line: "display: recording to" in line)
    publish(ros_env, float64_plan(range(0, 30, 6)))
    applied = wait_for_line(mirror, lambda line: line.startswith("[mirror") and "never" not in line)
    frames_then = displayed_frames(applied)
    wait_for_line(mirror, lambda line: line.startswith("[mirror") and displayed_frames(line) > frames_then)
    stop(mirror, tmp_path)
    video = cv2.VideoCapture(str(tmp_path / "joshua_output" / "mirror.mp4"))
    frames = []
    while (frame := video.read()[1]) is not None:
        frames.append(frame.astype(int))
    assert len(frames) >= 2 and frames[0].shape == (120, 160, 3)
    assert max(float(abs(frame - frames[0]).mean()) for frame in frames) > 1.0  # the arm moved on screen


def wait_for_line(mirror: subprocess.Popen[str], wanted: Callable[[str], bool]) -> str:
    """The mirror's next stderr line for which `wanted` is true (status lines keep readline from blocking long)."""
    assert mirror.stderr is not None
    deadline = time.monotonic() + 60
    while not wanted(line := mirror.stderr.readline()):
        assert line and time.monotonic() < deadline, "the mirror never printed the line waited for"
    return line


def wait_until_all_stale(mirror: subprocess.Popen[str]) -> None:
    """Read the mirror's stderr until its stale warnings have named every joint (one line or several)."""
    named: set[str] = set()
    while len(named) < len(JOINTS):
        line = wait_for_line(mirror, lambda line: "stale, no valid value" in line)
        named |= {joint for joint in JOINTS if f"{joint} (" in line}


def displayed_frames(status_line: str) -> int:
    """The frame count at the end of a status line: '... | display 42 frames'."""
    return int(status_line.rsplit("| display ", 1)[1].split()[0])


RECORD_CONFIG = """
extends: "sim_mirror"
simulation {
  render_width: 32
  render_height: 24
  mirror {
    display: NONE
    status_period: 0.2
    record { csv: true lerobot: true fps: 25 task: "follow" }
    command_topics { key: "joint_1_position" value: "/command/joint_1" }
    command_topics { key: "joint_2_position" value: "/command/joint_2" }
    command_topics { key: "joint_6_position" value: "/command/joint_6" }
  }
}
"""


@pytest.mark.slow
def test_mirror_records_the_motion_and_commands_it_receives(tmp_path: Path, ros_env: dict[str, str]) -> None:
    """`joshua mirror-replay` publishes a CSV's positions (encoders) and targets (commands); the mirror's
    recording reads back through load_trajectory, as a CSV and as a LeRobot dataset, on the published path."""
    from joshua_modes import model_joint_ranges
    from joshua_mujoco import compile_model

    times = np.arange(76) * 0.02  # 1.5 s at 50 Hz; slow enough that a row sampled between topics stays close

    def joint_values(t: np.ndarray) -> np.ndarray:
        return np.array([0.3 * np.sin(2 * t + i) + (0.6 if i == 5 else 0.1) for i in range(6)]).T

    published = Trajectory(Path("published.csv"), tuple(JOINTS), times, joint_values(times), np.arange(76),
                           joint_values(times + 0.1))  # fmt: skip
    csv, config = tmp_path / "published.csv", tmp_path / "record.pbtxt"
    write_trajectory(csv, published)
    config.write_text(RECORD_CONFIG)
    mirror = subprocess.Popen(
        [str(JOSHUA), "--config", str(config)], cwd=tmp_path, env=ros_env, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    replay = subprocess.run(
        [str(JOSHUA), "mirror-replay", str(csv), "--config", str(config), "--rate", "50"],
        cwd=tmp_path, env=ros_env, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert replay.returncode == 0, replay.stderr
    report, _ = stop(mirror, tmp_path)
    output = tmp_path / "joshua_output"
    recording = report["recording"]
    assert (tmp_path / recording["csv"]).samefile(output / "mirror_recording.csv") and recording["rows"] > 25
    assert (tmp_path / recording["lerobot"]).samefile(output / "mirror_lerobot")

    ranges = model_joint_ranges(compile_model(models_dir() / "so_arm100" / "scene.xml"))
    plugins = PluginHost.discover()
    recorded = load_trajectory(output / "mirror_recording.csv", ranges, plugins=plugins)
    assert recorded.joint_names == tuple(JOINTS) and recorded.targets is not None
    assert np.isnan(recorded.targets[:, [2, 3, 4]]).all()  # no command topic: no target
    assert_on_path(recorded.timestamps, recorded.positions, published.timestamps, published.positions)
    commanded = [0, 1, 5]
    assert_on_path(recorded.timestamps, recorded.targets[:, commanded], times, published.targets[:, commanded])

    dataset = load_trajectory(
        output / "mirror_lerobot", ranges, plugins=plugins
    )  # the same recording, resampled at 25 fps
    assert np.allclose(np.diff(dataset.timestamps), 0.04, atol=1e-6)
    assert_on_path(dataset.timestamps, dataset.positions, published.timestamps, published.positions)


def assert_on_path(
    times: np.ndarray, values: np.ndarray, path_times: np.ndarray, path: np.ndarray, tolerance: float = 0.03
) -> None:
    """Every recorded row lies on the published path (nearest published row within `tolerance` rad), in order,
    at a steady delay (within 0.1 s), and the recording covers the path from its start to its end."""
    nearest = np.array([np.abs(path - row).max(axis=1).argmin() for row in values])
    distance = np.array([np.abs(path[k] - row).max() for k, row in zip(nearest, values, strict=True)])
    assert distance.max() < tolerance, distance.max()
    moving = np.flatnonzero(np.diff(nearest) > 0) + 1  # rows recorded while the motion went on (not the still tail)
    assert np.all(np.diff(nearest) >= -1)  # in order (one row back: two published rows that look alike)
    assert nearest[0] <= 3 and nearest[-1] >= len(path) - 3
    delays = times[moving] - path_times[nearest[moving]]
    assert np.ptp(delays) < 0.1, delays


@pytest.mark.slow
def test_recording_keeps_its_rate_while_the_display_records_video(tmp_path: Path, ros_env: dict[str, str]) -> None:
    """The CSV recording is sampled at its configured fps whatever the display costs: with display RECORD at
    640x480 a frame takes longer than a sample period, yet the rows come 1/30 s apart (median within 10 %) and
    their number matches 30 per second of recording (within 15 %). No timing is assumed: the test waits for the
    status lines after the values arrived, then stops the mirror."""
    settings = (
        "simulation.mirror.display=RECORD",
        "simulation.render_width=640",
        "simulation.render_height=480",
        "simulation.mirror.record.csv=true",
        "simulation.mirror.record.fps=30",
    )
    mirror = start_mirror(tmp_path, {k: v for k, v in ros_env.items() if k != "DISPLAY"}, *settings)
    wait_for_line(mirror, lambda line: "display: recording to" in line)
    publish(ros_env, float64_plan(range(0, 30, 6)))
    wait_for_line(mirror, lambda line: line.startswith("[mirror") and "never" not in line)
    for _ in range(5):  # about a second of recording (status lines every 0.2 s, later when the machine is busy)
        wait_for_line(mirror, lambda line: line.startswith("[mirror"))
    report, _ = stop(mirror, tmp_path)
    timestamps = read_trajectory(tmp_path / "joshua_output" / "mirror_recording.csv").timestamps
    assert report["recording"]["rows"] == len(timestamps) > 10
    assert abs(np.median(np.diff(timestamps)) - 1 / 30) < 0.1 / 30, np.diff(timestamps)
    assert abs((len(timestamps) - 1) / timestamps[-1] - 30) < 0.15 * 30, (len(timestamps), timestamps[-1])
