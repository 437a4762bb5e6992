"""LeRobot datasets against the real `lerobot` 0.4.4: ours load in `LeRobotDataset` (frames, values, decoded
video), and one written by lerobot's own writer replays and validates through `load_trajectory` and PASSIVE.

lerobot runs in a subprocess (tests/lerobot_side.py) over the pinned packages `./setup.sh --dev` installs in
.cache/lerobot-site (tests/lerobot-requirements.txt): they must not change .venv.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from joshua_core.plugins import PluginHost
from joshua_core.resources import models_dir
from joshua_core.trajectory import Trajectory, write_trajectory
from joshua_core.trajectory_sources import load_trajectory
from joshua_lerobot import export_trajectory
from joshua_modes import iter_offscreen_frames, model_joint_ranges
from joshua_mujoco import compile_model

REPO = Path(__file__).resolve().parents[3]
LEROBOT_SITE = REPO / ".cache" / "lerobot-site"
SIDE = Path(__file__).with_name("lerobot_side.py")
MODEL = models_dir() / "so_arm100" / "scene.xml"
JOINTS = tuple(f"joint_{i}" for i in range(1, 7))
FPS = 10
PLUGINS = PluginHost.discover()  # the installed plugins: their readers read the datasets
WIDTH, HEIGHT = 64, 48


def lerobot(command: str, root: Path, tmp_path: Path) -> dict[str, Any]:
    """Run tests/lerobot_side.py COMMAND ROOT with the real lerobot; its JSON answer."""
    if not (LEROBOT_SITE / "lerobot").is_dir():
        pytest.fail(f"lerobot is not installed in {LEROBOT_SITE}: run ./setup.sh --dev")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(LEROBOT_SITE), env.get("PYTHONPATH", "")])
    env |= {"HF_HUB_OFFLINE": "1", "HF_HOME": str(tmp_path / "hf"), "HF_LEROBOT_HOME": str(tmp_path / "hf/lerobot")}
    result = subprocess.run(
        [sys.executable, str(SIDE), command, str(root)], env=env, capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return json.loads(result.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def ranges() -> dict[str, tuple[float, float]]:
    return model_joint_ranges(compile_model(MODEL))


def motion(ranges: dict[str, tuple[float, float]]) -> Trajectory:
    """1.5 s of smooth motion inside every joint's range, with targets leading the positions by 50 ms."""
    times = np.linspace(0.0, 1.5, 31)
    mids = np.array([(ranges[j][0] + ranges[j][1]) / 2 for j in JOINTS])
    spans = np.array([ranges[j][1] - ranges[j][0] for j in JOINTS])

    def at(t: np.ndarray) -> np.ndarray:
        return mids + 0.25 * spans * np.sin(2 * t[:, None] + np.arange(6))

    return Trajectory(Path("motion.csv"), JOINTS, times, at(times), np.arange(31), at(times + 0.05))


def test_our_dataset_loads_in_lerobot(tmp_path: Path, ranges: dict[str, tuple[float, float]]) -> None:
    csv = tmp_path / "motion.csv"
    trajectory = motion(ranges)
    write_trajectory(csv, trajectory)
    root = export_trajectory(
        csv, MODEL, tmp_path / "dataset", fps=FPS, size=(WIDTH, HEIGHT), task="wave", plugins=PLUGINS
    )
    loaded = lerobot("load", root, tmp_path)

    frames = 16  # 1.5 s at 10 fps, both ends
    assert (loaded["frames"], loaded["episodes"], loaded["fps"]) == (frames, 1, FPS)
    assert loaded["task"] == ["wave"] * frames
    assert np.allclose(loaded["timestamp"], np.arange(frames) / FPS, atol=1e-6)
    times = np.arange(frames) / FPS
    degrees = np.degrees  # SO-100 arm joints: degrees from the middle of the range; gripper 0..100
    low, high = ranges["joint_6"]
    for key, values in (("state", trajectory.positions), ("action", trajectory.targets)):
        expected = np.stack([np.interp(times, trajectory.timestamps, column) for column in values.T], axis=1)
        mids = np.array([(ranges[j][0] + ranges[j][1]) / 2 for j in JOINTS[:5]])
        arm = degrees(expected[:, :5] - mids)
        gripper = (expected[:, 5] - low) / (high - low) * 100
        assert np.allclose(np.array(loaded[key]), np.column_stack([arm, gripper]), atol=1e-3), key

    (camera,) = loaded["cameras"].values()
    assert camera["shape"] == [3, HEIGHT, WIDTH]
    frames = iter_offscreen_frames(MODEL, csv, WIDTH, HEIGHT, fps=FPS, plugins=PLUGINS)
    rendered = [frame.mean() / 255 for frame in frames]
    assert np.allclose(camera["mean"], rendered, atol=0.02)  # each decoded frame is the one rendered


def test_lerobot_dataset_replays_and_validates(tmp_path: Path, ranges: dict[str, tuple[float, float]]) -> None:
    root = tmp_path / "recorded"
    written = lerobot("write", root, tmp_path)
    low, high = ranges["joint_6"]
    for episode, expected in enumerate(written["episodes"]):
        trajectory = load_trajectory(root, ranges, episode=episode, plugins=PLUGINS)
        assert trajectory.joint_names == JOINTS
        assert np.allclose(trajectory.timestamps, np.arange(len(expected["state"])) / written["fps"], atol=1e-6)
        for values, lerobot_values in (
            (trajectory.positions, expected["state"]),
            (trajectory.targets, expected["action"]),
        ):
            source = np.array(lerobot_values)
            assert values is not None
            assert np.allclose(values[:, :5], np.radians(source[:, :5]), atol=1e-6)  # ranges are symmetric about 0
            assert np.allclose(values[:, 5], low + source[:, 5] / 100 * (high - low), atol=1e-6)

    output = tmp_path / "out"
    command = [
        sys.executable, "-m", "joshua_core.cli", "--preset", "sim_passive", "--strict",
        "--set", f"simulation.trajectory_path={root}", "--set", "simulation.replay.episode=1",
        "--set", f"simulation.output_dir={output}", "--set", "simulation.viewer.display=RECORD",
        "--set", "simulation.viewer.fps=5",
        "--set", "simulation.render_width=64", "--set", "simulation.render_height=48",
    ]  # fmt: skip
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    report = json.loads((output / "passive_report.json").read_text())
    assert report["ok"], report["issues"]
    assert report["rows"] == report["replayed_rows"] == len(written["episodes"][1]["state"])
    assert (output / "passive_replay.mp4").stat().st_size > 0


def test_bad_datasets_and_episodes_are_one_line_errors(tmp_path: Path) -> None:
    out = tmp_path / "dataset"
    export = [str(Path(sys.executable).parent / "joshua"), "lerobot-export"]
    csv = models_dir() / "trajectories" / "so_arm100_example.csv"
    made = subprocess.run(
        [*export, str(csv), "--out", str(out), "--no-video", "--fps", "5"], capture_output=True, text=True
    )
    assert made.returncode == 0, made.stderr
    replay = [
        str(Path(sys.executable).parent / "joshua"),
        "--preset",
        "sim_passive",
        "--set",
        f"simulation.trajectory_path={out}",
    ]
    result = subprocess.run([*replay, "--set", "simulation.replay.episode=4"], capture_output=True, text=True)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert f"{out}: no episode 4; the dataset has episodes 0..0 (1)" in result.stderr
    info = out / "meta" / "info.json"
    info.write_text(info.read_text().replace('"v3.0"', '"v2.1"'))
    result = subprocess.run(replay, capture_output=True, text=True)
    assert result.returncode == 2 and "LeRobot dataset format v2.1, this reader reads v3.0" in result.stderr


def test_out_replaces_only_a_dataset_joshua_wrote_and_only_with_overwrite(tmp_path: Path) -> None:
    joshua = str(Path(sys.executable).parent / "joshua")
    csv = str(models_dir() / "trajectories" / "so_arm100_example.csv")

    def export(out: str, *extra: str) -> subprocess.CompletedProcess[str]:
        command = [joshua, "lerobot-export", csv, "--out", out, "--no-video", "--fps", "5", *extra]
        return subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=300)

    def refused(done: subprocess.CompletedProcess[str], message: str) -> None:
        assert done.returncode == 2 and done.stderr.strip().count("\n") == 0 and message in done.stderr, done.stderr

    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    (tmp_path / "file").write_text("keep")
    for extra in ((), ("--overwrite",)):
        refused(export("mine", *extra), "was not written by joshua")
        refused(export("file", *extra), "is a file")
        refused(export(".", *extra), "names no folder of its own")
    assert (mine / "notes.txt").read_text() == "keep" and (tmp_path / "file").read_text() == "keep"

    assert export("dataset").returncode == 0
    refused(export("dataset"), "exists; pass --overwrite")
    (tmp_path / "dataset" / "meta" / "info.json").write_text("{}")
    done = export("dataset", "--overwrite")
    assert done.returncode == 0, done.stderr
    assert json.loads((tmp_path / "dataset" / "meta" / "info.json").read_text())["fps"] == 5  # written anew
    assert sorted(path.name for path in tmp_path.iterdir()) == ["dataset", "file", "mine"]  # no temporaries left
