"""SB3 without any working GL, for real (an unknown MUJOCO_GL, an EGL without a driver): training needs no GL at
all, and `joshua eval --video` writes its numbers and says, once, why there is no video."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from joshua_sb3.run_folder import KEY_ENV_VAR

JOSHUA = [sys.executable, "-m", "joshua_core.cli"]
SETTINGS = {  # one update of 4 x 16 steps
    "num_envs": 4, "num_steps": 16, "minibatch_size": 32, "num_epochs": 1, "total_timesteps": 64,
    "checkpoint_dir": "runs", "run_name": "reach",
}  # fmt: skip


def joshua(*args: str, cwd: Path, **gl: str) -> subprocess.CompletedProcess[str]:
    environment = {key: value for key, value in os.environ.items() if key not in ("DISPLAY", "WAYLAND_DISPLAY")}
    environment |= {KEY_ENV_VAR: str(cwd / "checkpoint.key"), **gl}
    return subprocess.run([*JOSHUA, *args], cwd=cwd, env=environment, capture_output=True, text=True, timeout=300)


@pytest.mark.slow
def test_training_and_eval_go_on_without_gl(tmp_path: Path) -> None:
    overrides = [arg for name, value in SETTINGS.items() for arg in ("--set", f"training.{name}={value}")]
    trained = joshua("--preset", "so_arm100_reach_sb3", *overrides, cwd=tmp_path, MUJOCO_GL="bogus")
    assert trained.returncode == 0, trained.stderr[-3000:]
    assert "joshua: warning" not in trained.stderr and (tmp_path / "runs" / "reach_step_64").is_dir()

    no_egl_driver = {"MUJOCO_GL": "egl", "__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent/egl_vendor.json"}
    evaluated = joshua("eval", "runs/reach", "--episodes", "2", "--video", "eval.mp4", cwd=tmp_path, **no_egl_driver)
    assert evaluated.returncode == 0, evaluated.stderr[-3000:]
    [warning] = [line for line in evaluated.stderr.splitlines() if line.startswith("joshua: warning:")]
    assert warning.startswith("joshua: warning: no video (nor other pictures) in this run: rendering failed with")
    assert "apt-get install libegl1 libgl1-mesa-dri" in warning and "libosmesa6" in warning
    assert "mean_return:" in evaluated.stdout and not (tmp_path / "eval.mp4").exists()
    assert json.loads((tmp_path / "runs" / "reach" / "eval.json").read_text())["per_episode"]["length"] == [100, 100]
