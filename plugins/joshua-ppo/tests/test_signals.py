"""Ctrl-C (or SIGTERM) while the ppo trainer trains: the iteration in progress ends, a checkpoint is saved, the
command that resumes the run is printed, the exit status is 130 (143) with no traceback, and that command
continues the run."""

from __future__ import annotations

import os
import shlex
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from joshua_core.runs import checkpoint_step, run_checkpoints

pytestmark = pytest.mark.slow  # every test here trains

JOSHUA = [sys.executable, "-m", "joshua_core.cli"]
# 4 environments x 5 steps per iteration on MuJoCo Warp, whose steps (Python callbacks on XLA's threads) must also
# finish when the run stops: compiles in seconds on the CPU
SETTINGS = {
    "mjx.impl": "WARP", "num_envs": 4, "num_steps": 5, "minibatch_size": 20, "num_epochs": 1, "total_timesteps": 10**9,
    "checkpoint_dir": "runs", "ppo.viewer": "OFF", "ppo.video_interval": -1, "hidden_sizes": "[16]",
    "run_name": "stopped",
}  # fmt: skip
OVERRIDES = [arg for name, value in SETTINGS.items() for arg in ("--set", f"training.{name}={value}")]
ARGS = ["--preset", "ant_train_mjx", *OVERRIDES]
ENVIRONMENT = {**os.environ, "PYTHONUNBUFFERED": "1"}


def stop_a_run(tmp_path: Path, signum: int) -> tuple[str, int]:
    """Start a run, send `signum` once it compiles, check how it ended; its stdout and the step it stopped at."""
    process = subprocess.Popen(
        [*JOSHUA, *ARGS], cwd=tmp_path, env=ENVIRONMENT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert process.stdout is not None
    watchdog = threading.Timer(300, process.kill)  # a run that never says it started fails, not hangs
    watchdog.start()
    for line in process.stdout:
        if "compiling the training iteration" in line:
            break
    process.send_signal(signum)
    stdout, stderr = process.communicate(timeout=300)
    watchdog.cancel()
    assert process.returncode == 128 + signum, stderr[-2000:]
    assert "Traceback" not in stderr and stderr.strip().endswith("joshua: interrupted")
    run_dir = tmp_path / "runs" / "stopped"
    stopped_at = checkpoint_step(run_checkpoints(run_dir.parent, run_dir.name)[-1])
    assert stopped_at > 0 and f"ppo: stopped at {stopped_at} steps; checkpoint runs/stopped_step_{stopped_at}" in stdout
    return stdout, stopped_at


def test_sigterm_saves_a_checkpoint(tmp_path: Path) -> None:
    """A job scheduler's SIGTERM ends the run like Ctrl-C, with exit status 143."""
    stop_a_run(tmp_path, signal.SIGTERM)


def test_ctrl_c_saves_a_checkpoint_and_says_how_to_resume(tmp_path: Path) -> None:
    stdout, stopped_at = stop_a_run(tmp_path, signal.SIGINT)
    run_dir = tmp_path / "runs" / "stopped"
    command = next(line for line in stdout.splitlines() if line.startswith("resume with: "))
    argv = shlex.split(command.removeprefix("resume with: "))
    assert argv[1:] == [*ARGS, "--set", "training.resume=true"]

    total = stopped_at + 20
    resumed = subprocess.run(
        [*JOSHUA, *argv[1:], "--set", f"training.total_timesteps={total}"],
        cwd=tmp_path,
        env=ENVIRONMENT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    assert f"from stopped_step_{stopped_at} ({stopped_at} steps)" in resumed.stdout
    assert run_checkpoints(run_dir.parent, run_dir.name)[-1].name == f"stopped_step_{total}"
