"""A USD file is a model_path like any other: the example trajectory rendered offscreen and replayed with its
validation on the exported SO-ARM100 (models/isaac/so100.usd), and PPO (JAX environments on MJX) trained
through the `usd` backend from the USD Ant."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import cv2
import pytest

from joshua_core.runs import run_checkpoints

JOSHUA = Path(sys.executable).parent / "joshua"
SO100 = ("--set", "simulation.model_path=isaac/so100.usd", "--set", "simulation.output_dir=out")
TINY = ("--set", "simulation.render_width=64", "--set", "simulation.render_height=48")


def joshua(cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    result = subprocess.run([str(JOSHUA), *args], cwd=cwd, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    return result


def test_offscreen_renders_the_example_trajectory_on_the_usd_arm(tmp_path: Path) -> None:
    joshua(tmp_path, "--preset", "sim_offscreen", *SO100, *TINY)
    video = cv2.VideoCapture(str(tmp_path / "out" / "offscreen.mp4"))
    frames = []
    while (frame := video.read())[0]:
        frames.append(frame[1])
    assert len(frames) > 100 and frames[0].shape == (48, 64, 3)
    assert max(float(abs(frame.astype(int) - frames[0]).mean()) for frame in frames) > 0.5  # the arm moves


def test_passive_validates_and_replays_the_example_on_the_usd_arm(tmp_path: Path) -> None:
    joshua(tmp_path, "--preset", "sim_passive", *SO100, *TINY, "--strict", "--set", "simulation.viewer.display=RECORD")
    report = json.loads((tmp_path / "out" / "passive_report.json").read_text())
    assert report["ok"] is True and report["issues"] == [] and report["replayed_rows"] == report["rows"], report
    assert (tmp_path / "out" / "passive_replay.mp4").stat().st_size > 0


@pytest.mark.slow
def test_ppo_trains_on_mjx_through_the_usd_backend(tmp_path: Path) -> None:
    settings = {
        "framework": "MJX", "backend": "usd", "num_envs": 4, "num_steps": 5, "minibatch_size": 20, "num_epochs": 1,
        "total_timesteps": 40, "checkpoint_dir": "runs", "ppo.viewer": "OFF", "ppo.video_interval": -1,
        "hidden_sizes": "[16]", "run_name": "usd",
        "mjx.impl": "WARP",  # the backend's model is the subject: Warp's iteration compiles far sooner than MJX-JAX's
    }  # fmt: skip
    overrides = [arg for name, value in settings.items() for arg in ("--set", f"training.{name}={value}")]
    result = subprocess.run(
        [str(JOSHUA), "--preset", "isaac_ant_locomotion", *overrides],
        cwd=tmp_path,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert run_checkpoints(tmp_path / "runs", "usd")[-1].name == "usd_step_40"
