"""`joshua demos` against the real lerobot (tests/lerobot_side.py through tests/lerobot_harness.py) and against
the simulation: the dataset loads with `delta_timestamps` and decodes, its rows are the simulated joint angles and
the script's targets in LeRobot's units, and only the attempts that placed the cube are in it."""

from __future__ import annotations

import fcntl
import json
import os
import pty
import re
import select
import signal
import struct
import subprocess
import sys
import termios
import time
from pathlib import Path
from typing import Any

import av
import numpy as np
import pytest
from lerobot_harness import lerobot

from joshua_core.config import finalize, load_preset
from joshua_core.options import LENIENT
from joshua_lerobot import LeRobotReader
from joshua_mujoco import PickPlaceScript, make_vector_env

JOSHUA = str(Path(sys.executable).parent / "joshua")
TASK = "so_arm100_pick_place"
PRESET = "so_arm100_pick_place_mjx_dr"
# Seed 6 over 3 environments: the second attempt leaves the cube off its goal, the other two place it
# (found by rolling seeds out; the test below checks that it still holds).
SEED, NUM_ENVS, FPS, STRIDE = 6, 3, 5, 10  # 5 fps: every 10th step of the 50 Hz task
WIDTH, HEIGHT = 64, 48
SUCCESS_RADIUS = 0.02  # m: the task's success metric (body_command_within)
JOINTS = tuple(f"joint_{i}" for i in range(1, 7))


def demos(out: Path, *options: str) -> subprocess.CompletedProcess[str]:
    command = [JOSHUA, "demos", "--out", str(out), *options]
    return subprocess.run(command, capture_output=True, text=True, timeout=600)


def simulated() -> list[dict[str, Any]]:
    """The attempts `joshua demos --seed SEED --num-envs NUM_ENVS` makes first, rolled out here step by step:
    per attempt the joint angles and the script's targets at every STRIDE-th step, each step's camera frame
    mean, and the cube's final distance to its goal."""
    task_config = finalize(load_preset(PRESET, LENIENT)).training.task_config
    env = make_vector_env(TASK, NUM_ENVS, seed=SEED, task_config=task_config)
    simulation = env.simulation
    model = simulation.model
    addresses = [model.joint(joint).qposadr[0] for joint in JOINTS]
    cube = model.body("cube").id
    scripts = [PickPlaceScript(model, simulation.task) for _ in range(NUM_ENVS)]
    plans = [
        script.actions(
            simulation.qpos[i].copy(), simulation.derived["xpos"][i, cube].copy(), simulation.commands["goal"][i]
        )
        for i, script in enumerate(scripts)
    ]
    attempts = [{"state": [], "action": [], "brightness": []} for _ in range(NUM_ENVS)]
    actions = [next(plan)[1] for plan in plans]
    step = 0
    while True:
        if step % STRIDE == 0:
            for i, attempt in enumerate(attempts):
                attempt["state"].append(simulation.qpos[i, addresses].copy())
                attempt["action"].append(scripts[i].in_force.copy())
                attempt["brightness"].append(env.render_frame(i, None, WIDTH, HEIGHT).mean() / 255)
        _, _, terminated, truncated, infos = env.step(np.stack(actions))
        assert not (terminated.any() or truncated.any())
        step += 1
        try:
            actions = [plan.send(simulation.qpos[i].copy())[1] for i, plan in enumerate(plans)]
        except StopIteration:
            break
    for i, attempt in enumerate(attempts):
        attempt["distance"] = float(infos["metrics"]["distance"][i])
    ranges = [tuple(model.jnt_range[model.joint(joint).id]) for joint in JOINTS]
    env.close()
    for attempt in attempts:
        for key in ("state", "action"):
            values = np.array(attempt[key])
            mids = np.array([(low + high) / 2 for low, high in ranges[:5]])
            low, high = ranges[5]
            attempt[key] = np.column_stack(
                [np.degrees(values[:, :5] - mids), (values[:, 5] - low) / (high - low) * 100]
            )
    return attempts


@pytest.mark.slow
def test_demos_keep_the_successful_attempts_and_lerobot_loads_them(tmp_path: Path) -> None:
    out = tmp_path / "demos"
    done = demos(out, "--episodes", "2", "--num-envs", str(NUM_ENVS), "--seed", str(SEED), "--fps", str(FPS),
                 "--width", str(WIDTH), "--height", str(HEIGHT), "--task", "place the cube")  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    assert "2 of 3 attempts succeeded" in done.stdout and "episodes/minute" in done.stdout, done.stdout

    attempts = simulated()
    placed = [attempt["distance"] < SUCCESS_RADIUS for attempt in attempts]
    assert placed == [True, False, True], [attempt["distance"] for attempt in attempts]  # the seed still has a miss
    kept = [attempt for attempt, ok in zip(attempts, placed, strict=True) if ok]

    loaded = lerobot("delta", out, tmp_path)
    rows = len(kept[0]["state"])  # 300 control steps of the script, every 10th
    assert rows == 30 and (loaded["frames"], loaded["episodes"], loaded["fps"]) == (2 * rows, 2, FPS)
    assert loaded["episode_index"] == [0] * rows + [1] * rows and loaded["task"] == ["place the cube"]
    state, action = np.array(loaded["observation.state"]), np.array(loaded["action"])
    first = np.arange(2 * rows) % rows == 0
    for episode, attempt in enumerate(kept):
        span = slice(episode * rows, (episode + 1) * rows)
        # degrees and percent of float32 values: 1e-3 is far below one encoder count (0.088 degrees)
        assert np.allclose(state[span, 1], attempt["state"], rtol=0, atol=1e-3)
        assert np.allclose(state[span, 0][1:], attempt["state"][:-1], rtol=0, atol=1e-3)  # the frame before
        assert np.allclose(action[span, 0], attempt["action"], rtol=0, atol=1e-3)
        assert np.allclose(action[span, 1][:-1], attempt["action"][1:], rtol=0, atol=1e-3)  # the next frame's
    assert np.array(loaded["observation.state_is_pad"])[:, 0].tolist() == first.tolist()
    assert np.array(loaded["action_is_pad"])[:, 2].tolist() == (np.arange(2 * rows) % rows >= rows - 2).tolist()

    (camera,) = loaded["cameras"].values()
    assert camera["shape"] == [2, 3, HEIGHT, WIDTH]
    decoded = np.array(camera["mean"])[:, 1]  # this frame's
    rendered = np.concatenate([attempt["brightness"] for attempt in kept])
    assert np.allclose(decoded, rendered, rtol=0, atol=0.02)  # mean brightness in [0, 1], through H.264
    assert np.array(camera["is_pad"])[:, 0].tolist() == first.tolist()


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (("--camera", "nowhere"), "no camera 'nowhere' in the model; cameras: overview, side"),
        (("--fps", "30"), "--fps 30 does not divide the task's control rate of 50 steps per second"),
        (("--width", "63"), "need an even width and height"),
        (("--preset", "so_arm100_train_mjx"), "the scripted controller demonstrates 'so_arm100_pick_place'"),
    ],
)
def test_user_errors_are_one_line_and_write_nothing(tmp_path: Path, options: tuple[str, ...], message: str) -> None:
    done = demos(tmp_path / "demos", "--episodes", "1", *options)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and message in done.stderr, done.stderr
    assert not (tmp_path / "demos").exists()


def test_an_existing_out_is_refused_before_any_rollout(tmp_path: Path) -> None:
    out = tmp_path / "demos"
    out.mkdir()
    (out / "notes.txt").write_text("keep")
    done = demos(out, "--episodes", "1")
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "was not written by joshua" in done.stderr
    assert (out / "notes.txt").read_text() == "keep"


def test_ctrl_c_writes_the_episodes_kept_before_it_as_a_dataset(tmp_path: Path) -> None:
    """A real SIGINT once the first episode is written (the progress bar says 1/50) stops the rollout under way at
    once; the episodes kept before it are a whole dataset, said in one line, and the run exits 130."""
    out = tmp_path / "demos"
    leader, follower = pty.openpty()  # stderr a terminal: the progress bar redraws as each episode is written
    fcntl.ioctl(follower, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 160, 0, 0))  # tqdm draws nothing 0 wide
    command = [JOSHUA, "demos", "--out", str(out), "--episodes", "50", "--num-envs", "1", "--seed", str(SEED),
               "--fps", str(FPS), "--width", "32", "--height", "24", "--physics", "cpu"]  # fmt: skip
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=follower, text=True)
    os.close(follower)
    terminal = b""
    try:
        deadline = time.monotonic() + 300
        while b" 1/50 episodes" not in terminal:
            assert select.select([leader], [], [], max(0.0, deadline - time.monotonic()))[0], terminal[-2000:]
            terminal += os.read(leader, 1 << 16)
        process.send_signal(signal.SIGINT)
        stdout, _ = process.communicate(timeout=120)
        while select.select([leader], [], [], 0)[0]:
            terminal += os.read(leader, 1 << 16)
    except OSError:  # the child's side of the terminal closed: all it wrote was read
        stdout, _ = process.communicate(timeout=120)
    finally:
        process.kill()
        os.close(leader)
    stderr = terminal.decode(errors="replace")
    assert process.returncode == 130 and "Traceback" not in stderr, stderr[-3000:]
    said = re.search(r"demos: interrupted; the dataset holds the (\d+) episode\(s\) kept before it", stderr)
    assert said is not None, stderr[-3000:]
    kept = int(said.group(1))
    assert kept >= 1 and f"LeRobot dataset: {out} ({kept} episodes, {30 * kept} frames)" in stdout, stdout

    info = json.loads((out / "meta" / "info.json").read_text())
    assert (info["total_episodes"], info["total_frames"]) == (kept, 30 * kept)
    ranges = {joint: (-3.0, 3.0) for joint in JOINTS}
    for episode in range(kept):
        assert len(LeRobotReader().read(out, ranges, episode=episode).timestamps) == 30
    (video,) = (out / "videos").rglob("*.mp4")
    with av.open(str(video)) as container:  # every frame kept is in the video, decodable
        assert sum(1 for _ in container.decode(video=0)) == 30 * kept


def test_the_cpu_producer_demonstrates_the_so101_under_its_presets_randomization() -> None:
    """`joshua demos --preset so101_pick_place_mjx_dr` rolls the script out on the SO-101's own task: its joints,
    named as LeRobot's motors, and the cube placed under the randomized preset's events."""
    from joshua_core.plugins import PluginHost
    from joshua_lerobot.joints import SO101_JOINTS
    from joshua_lerobot.scripted_rollouts import ScriptedMuJoCoProducer

    training = finalize(load_preset("so101_pick_place_mjx_dr", LENIENT)).training
    producer = ScriptedMuJoCoProducer(
        task=training.task, num_envs=1, cameras=[""], size=(WIDTH, HEIGHT), fps=1, seed=0,
        plugins=PluginHost.discover(), task_config=training.task_config,
    )  # fmt: skip
    try:
        rollout = next(producer.rollouts())
    finally:
        producer.close()
    assert producer.joint_names == tuple(SO101_JOINTS.values())
    assert rollout.success and rollout.length == 6  # 300 control steps at 50 Hz, a frame a second
