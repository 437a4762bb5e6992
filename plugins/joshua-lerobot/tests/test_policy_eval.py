"""`joshua eval` of a LeRobot policy: a real lerobot policy (the SAC actor: it loads and runs without
torchvision, which ACT's ResNet backbone needs; see tests/no_torchvision/sitecustomize.py), saved with
`save_pretrained` with the features a `joshua demos` dataset has, run by a "LeRobot Python" (tests/lerobot_harness.py)
while `joshua` runs without lerobot; its actions drive the simulated arm, and bad input is one line, exit 2."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from lerobot_harness import lerobot, lerobot_python, sac_policy_type

from joshua_core.config_pb2 import TaskConfig
from joshua_core.plugins import PluginHost
from joshua_core.run_context import RunContext
from joshua_lerobot.joints import DEFAULT_UNITS
from joshua_lerobot.policy_eval import DEFAULT_REPLY_SECONDS, evaluate_policy
from joshua_lerobot.policy_process import PolicyProcess

JOSHUA = str(Path(sys.executable).parent / "joshua")
TASK = "so_arm100_pick_place"
WIDTH, HEIGHT = 64, 48
# The commanded pose in LeRobot's SO-100 units (degrees from each joint's mid-range, gripper percent), far from the
# task's start pose: the policy's action range is this one point, so it commands it whatever it sees.
POSE = [30.0, -20.0, 25.0, 30.0, 20.0, 60.0]
SHORT = ("--set", "training.task_config.episode_length=50")  # 1 s episodes: the test is about the loop, not success


def save_policy(folder: Path, tmp_path: Path, inputs: dict[str, list[int]]) -> Path:
    request = tmp_path / f"{folder.name}.json"
    request.write_text(json.dumps({"inputs": inputs, "action_min": POSE, "action_max": POSE, "out": str(folder)}))
    assert lerobot("sac", request, tmp_path)["type"] == sac_policy_type()
    return folder


@pytest.fixture(scope="module")
def lerobot_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("lerobot")


@pytest.fixture(scope="module")
def policy(lerobot_folder: Path) -> Path:
    """A SAC actor taking the joint state and the overview camera, as a `joshua demos --camera overview` dataset."""
    inputs = {"observation.state": [6], "observation.images.overview": [3, HEIGHT, WIDTH]}
    return save_policy(lerobot_folder / "policy", lerobot_folder, inputs)


def joshua_eval(folder: Path, *options: str, python: Path | str) -> subprocess.CompletedProcess[str]:
    command = [JOSHUA, "eval", str(folder), "--lerobot-python", str(python), *options]
    return subprocess.run(command, capture_output=True, text=True, timeout=300)


@pytest.mark.slow
def test_joshua_eval_reports_a_lerobot_policys_success_rate_with_intervals(
    policy: Path, lerobot_folder: Path, tmp_path: Path
) -> None:
    results, video = tmp_path / "eval.json", tmp_path / "eval.mp4"
    done = joshua_eval(policy, "--episodes", "3", "--num-envs", "2", "--json", str(results), "--video", str(video),
                       "--grid", "2", *SHORT, python=lerobot_python(lerobot_folder))  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    assert "success rate 0.000 (0 of 3 episodes)" in done.stdout and "Wilson" in done.stdout, done.stdout
    assert "eval: 100%" in done.stderr and "150/150 env steps" in done.stderr, done.stderr[-2000:]  # 3 x 50 steps
    document = json.loads(results.read_text())
    assert document["policy_format"] == "lerobot" and "trainer" not in document
    assert document["episodes"] == 3 and document["successes"] == 0
    low, high = document["success_rate_ci95"]
    assert abs(low) < 1e-9 and 0.4 < high < 0.8 and document["mean_return_ci95"] is not None  # Wilson at n = 3
    per_episode = document["per_episode"]
    assert per_episode["length"] == [50.0] * 3 and len(per_episode["return"]) == 3 and len(per_episode["success"]) == 3
    assert video.stat().st_size > 0


@pytest.mark.slow
def test_the_policys_actions_drive_the_arm(policy: Path, lerobot_folder: Path) -> None:
    plugins = PluginHost.discover()
    with PolicyProcess(str(lerobot_python(lerobot_folder)), policy, "cpu", DEFAULT_REPLY_SECONDS) as process:
        assert process.description.type == sac_policy_type()
        evaluation = evaluate_policy(
            process,
            TASK,
            episodes=2,
            num_envs=2,
            seed=3,
            fps=25,
            units=DEFAULT_UNITS,
            context=RunContext(plugins, policy),
            task_config=TaskConfig(episode_length=100),
        )
    # 2 s of targets held at the pose: every joint there within a few degrees (the servos sag under gravity)
    reached = evaluation.last_states
    assert reached.shape == (2, 6)
    np.testing.assert_allclose(reached[:, :5], np.tile(POSE[:5], (2, 1)), atol=4.0)
    np.testing.assert_allclose(reached[:, 5], POSE[5], atol=10.0)  # the gripper closes on nothing


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("missing", "does not exist"),
        ("empty", "is not a run folder: it has no config.json"),
        ("no_lerobot", "lerobot cannot be imported by"),
        ("no_python", "--lerobot-python /nonexistent/python: cannot run it"),
        ("broken", "cannot load the policy"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(
    case: str, message: str, policy: Path, lerobot_folder: Path, tmp_path: Path
) -> None:
    folder, python = policy, str(lerobot_python(lerobot_folder))
    if case == "missing":
        folder = tmp_path / "nowhere"
    elif case == "empty":
        folder = tmp_path
    elif case == "no_lerobot":
        python = sys.executable  # JOSHUA's own Python: no lerobot
    elif case == "no_python":
        python = "/nonexistent/python"
    else:
        folder = tmp_path / "broken"
        folder.mkdir()
        (folder / "config.json").write_text(json.dumps({"type": sac_policy_type(), "input_features": 3}))
        (folder / "model.safetensors").write_bytes(b"not a model")
    done = joshua_eval(folder, "--no-video", *SHORT, python=python)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and message in done.stderr, done.stderr


@pytest.mark.slow
def test_a_policy_taking_a_camera_the_task_lacks_is_refused_naming_it(lerobot_folder: Path, tmp_path: Path) -> None:
    inputs = {"observation.state": [6], "observation.images.wrist": [3, HEIGHT, WIDTH]}
    folder = save_policy(tmp_path / "wrist", tmp_path, inputs)
    done = joshua_eval(folder, "--no-video", *SHORT, python=lerobot_python(lerobot_folder))
    expected = (
        f"the {sac_policy_type()} policy takes observation.images.wrist, which the task does not provide (it provides "
        "observation.state, observation.images.overview, observation.images.side)"
    )
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and expected in done.stderr, done.stderr
    assert not (folder / "eval.json").exists()


MISBEHAVING = Path(__file__).with_name("misbehaving_policy.py")


def misbehaving_python(tmp_path: Path, answer: str) -> str:
    """An executable `--lerobot-python` whose "policy" is tests/misbehaving_policy.py answering as `answer` says."""
    script = tmp_path / f"python-{answer}"
    script.write_text(f"#!/bin/sh\nexport JOSHUA_TEST_ANSWER={answer}\nexec '{sys.executable}' '{MISBEHAVING}'\n")
    script.chmod(0o755)
    return str(script)


@pytest.mark.parametrize(
    ("answer", "message"),
    [
        ("one_row", "answered a batch of 4 observations with actions of shape [1, 6], not [4, 6]"),
        ("one_d", "answered a batch of 4 observations with actions of shape [6], not [4, 6]"),
        ("too_wide", "answered a batch of 4 observations with actions of shape [4, 7], not [4, 6]"),
        ("nan", "answered with non-finite actions (NaN or infinity) in 1 of 4 rows"),
        ("strings", "sent what is not a reply (array 'action': dtype <U1 is not a number)"),
        ("not_json", "sent what is not a reply (Expecting property name enclosed in double quotes"),
        ("deep_json", "sent what is not a reply (a header nested too deeply)"),
        ("huge_length", "sent what is not a reply (a header of 4294967295 bytes (at most 1048576))"),
        ("huge_shape", "sent what is not a reply (array 'action': shape [1099511627776, 1099511627776] is not"),
        ("huge_total", "sent what is not a reply (arrays of 4398046511104 bytes (at most 67108864))"),
        ("short_then_exit", "sent what is not a reply (the message ended after 8 of 96 bytes)"),
        ("dies", "the policy process ended without a reply (exit 3)"),
    ],
)
def test_a_policy_answering_wrongly_is_stopped_with_one_line(answer: str, message: str, tmp_path: Path) -> None:
    """An answer that is not one finite row per observation is refused, never spread over the batch, and a reply
    that is not a message ends the policy process."""
    from joshua_core.errors import UsageError

    process = PolicyProcess(misbehaving_python(tmp_path, answer), tmp_path, "cpu", 120.0)
    try:
        with pytest.raises(UsageError) as refused:
            process.select_action(np.zeros((4, 6), np.float32), {}, ["task"] * 4)
        assert message in str(refused.value) and "\n" not in str(refused.value)
        assert process.process.wait(timeout=30) is not None  # stopped, or ended by itself
    finally:
        process.close()


@pytest.mark.parametrize("answer", ["hang_loading", "partial_description"])
def test_a_policy_that_stops_answering_is_stopped_at_the_deadline(answer: str, tmp_path: Path) -> None:
    from joshua_core.errors import UsageError

    started = time.monotonic()
    with pytest.raises(UsageError, match=r"the policy process did not answer within 1 s \(--lerobot-timeout\)"):
        PolicyProcess(misbehaving_python(tmp_path, answer), tmp_path, "cpu", 1.0)
    assert 1.0 <= time.monotonic() - started < 60  # the deadline, plus the process's stop


def test_a_policy_describing_itself_wrongly_is_one_line(tmp_path: Path) -> None:
    from joshua_core.errors import UsageError

    with pytest.raises(UsageError, match="the policy process described its policy wrongly"):
        PolicyProcess(misbehaving_python(tmp_path, "no_description"), tmp_path, "cpu", 120.0)


def test_joshua_eval_of_a_policy_answering_one_row_for_the_batch_is_exit_2(tmp_path: Path) -> None:
    """The broadcast finding: `joshua eval` of such a policy stops with one line and writes no results."""
    folder = tmp_path / "policy"
    folder.mkdir()
    (folder / "config.json").write_text(json.dumps({"type": "fake"}))
    (folder / "model.safetensors").write_bytes(b"")
    done = joshua_eval(folder, "--no-video", "--num-envs", "2", "--episodes", "2", *SHORT,
                       python=misbehaving_python(tmp_path, "one_row"))  # fmt: skip
    said = [line for line in done.stderr.splitlines() if not line.startswith("eval:")]  # the progress lines aside
    assert done.returncode == 2 and len(said) == 1, done.stderr
    assert "answered a batch of 2 observations with actions of shape [1, 6], not [2, 6]" in said[0]
    assert not (folder / "eval.json").exists()
