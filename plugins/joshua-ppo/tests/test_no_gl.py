"""PPO without any working GL, for real (an EGL without a driver, an unknown MUJOCO_GL): training keeps its
checkpoints and metrics and warns once that there are no videos; `joshua eval` writes its numbers and says why
there is no video."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).parent
NO_EGL_DRIVER = {"MUJOCO_GL": "egl", "__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent/egl_vendor.json"}
SLIDER = {  # one iteration of distributed_worker.py's slider task, a video asked for at every checkpoint
    "task": "slider_reach", "backend": "mjx", "num_envs": 4, "num_steps": 5, "minibatch_size": 20, "num_epochs": 1,
    "total_timesteps": 20, "checkpoint_dir": "runs",
    "run_name": "slider", "hidden_sizes": [8], "ppo": {"video_interval": 0},
}  # fmt: skip


def run(script: str, *args: str, cwd: Path, **gl: str) -> subprocess.CompletedProcess[str]:
    environment = {key: value for key, value in os.environ.items() if key not in ("DISPLAY", "WAYLAND_DISPLAY")}
    return subprocess.run(
        [sys.executable, str(HERE / script), *args],
        cwd=cwd,
        env={**environment, **gl},
        capture_output=True,
        text=True,
        timeout=300,
    )


def warnings(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("joshua: warning:")]


@pytest.mark.slow
def test_training_and_eval_go_on_without_gl(tmp_path: Path) -> None:
    trained = run("distributed_worker.py", json.dumps(SLIDER), str(tmp_path), cwd=tmp_path, **NO_EGL_DRIVER)
    assert trained.returncode == 0, trained.stderr[-3000:]
    [warning] = warnings(trained.stderr)
    assert warning.startswith("joshua: warning: no videos (nor other pictures) in this run: rendering failed with")
    assert "apt-get install libegl1 libgl1-mesa-dri" in warning and "libosmesa6" in warning
    runs = tmp_path / "runs"
    assert (runs / "slider_step_20" / "params.msgpack").is_file() and not (runs / "slider" / "videos").exists()
    assert json.loads((runs / "slider" / "metrics.json").read_text())["history"]

    evaluated = run("eval_worker.py", "runs/slider", "--episodes", "2", "--video", "eval.mp4", cwd=tmp_path,
                    MUJOCO_GL="bogus")  # fmt: skip
    assert evaluated.returncode == 0, evaluated.stderr[-3000:]
    assert warnings(evaluated.stderr) == [
        "joshua: warning: no videos (nor other pictures) in this run: MUJOCO_GL=bogus is no OpenGL platform MuJoCo "
        "knows; set MUJOCO_GL=egl or MUJOCO_GL=osmesa (without a display), glfw (with one), or unset it"
    ]
    assert "mean_return:" in evaluated.stdout and not (tmp_path / "eval.mp4").exists()
    assert json.loads((runs / "slider" / "eval.json").read_text())["per_episode"]["length"] == [10, 10]
