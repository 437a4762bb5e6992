"""Bad ROS names (a topic, a node name) in a MIRROR config or on the command line: one line naming the field,
exit 2, before any ROS node is made, for the mirror, `mirror-replay` and `deploy` alike (no ROS graph needed)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from joshua_core.errors import UsageError
from joshua_mirror.names import check_node_name, check_topic

JOSHUA = Path(sys.executable).parent / "joshua"
TOPIC = "simulation.mirror_topic_mappings.mappings[0].ros_topic"


@pytest.mark.parametrize(
    ("topic", "reason"),
    [
        ("bad topic", "must not contain characters other than"),
        ("a//b", "must not contain repeated '/'"),
        ("/a/", "must not end with a forward slash"),
        ("{x}", "unknown substitution"),
        ("", "must not be empty"),
    ],
)
def test_a_bad_topic_name_is_one_line_naming_the_field(topic: str, reason: str) -> None:
    with pytest.raises(UsageError) as raised:
        check_topic(topic, "--estop-topic")
    message = str(raised.value)
    assert message.startswith(f"--estop-topic: {topic!r} is not a ROS topic name: ") and reason in message, message
    assert "\n" not in message and ".c:" not in message


def test_good_names_pass() -> None:
    for topic in ("/joint_states", "encoder/joint_1", "~/target"):
        assert check_topic(topic, "topic") == topic
    assert check_node_name("joshua_mirror", "node") == "joshua_mirror"


def joshua(*args: str, cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(JOSHUA), *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=120)


def assert_one_line(result: subprocess.CompletedProcess[str], message: str) -> None:
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr[-2000:]
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], lines


def test_the_mirror_refuses_a_bad_node_name(tmp_path: Path, ros_env: dict[str, str]) -> None:
    bad_name = "simulation.mirror.node_name=bad name"
    result = joshua("--preset", "sim_mirror", "--set", bad_name, cwd=tmp_path, env=ros_env)
    assert_one_line(result, "simulation.mirror.node_name: 'bad name' is not a ROS node name: node name must not")


def test_mirror_replay_refuses_a_bad_topic_and_node_name(tmp_path: Path, ros_env: dict[str, str]) -> None:
    csv = tmp_path / "never_read.csv"
    result = joshua("mirror-replay", str(csv), "--set", f"{TOPIC}=bad topic", cwd=tmp_path, env=ros_env)
    assert_one_line(result, f"{TOPIC}: 'bad topic' is not a ROS topic name")
    result = joshua("mirror-replay", str(csv), "--set", "simulation.mirror.node_name=1st", cwd=tmp_path, env=ros_env)
    assert_one_line(result, "simulation.mirror.node_name: '1st' is not a ROS node name")


def test_deploy_refuses_bad_topic_options(tmp_path: Path, ros_env: dict[str, str]) -> None:
    result = joshua("deploy", str(tmp_path), "--estop-topic", "e stop", cwd=tmp_path, env=ros_env)
    assert_one_line(result, "--estop-topic: 'e stop' is not a ROS topic name")
    result = joshua("deploy", str(tmp_path), "--target-topic", "/t/", cwd=tmp_path, env=ros_env)
    assert_one_line(result, "--target-topic: '/t/' is not a ROS topic name: topic name must not end with")
