"""Ctrl-C (SIGINT) or SIGTERM while the sb3 trainer trains: a checkpoint is saved, the command that resumes
the run is printed, the exit status is 130 or 143 with no traceback, and that command continues the run."""

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
from joshua_sb3.run_folder import KEY_ENV_VAR

pytestmark = pytest.mark.slow  # every test here trains

JOSHUA = Path(sys.executable).parent / "joshua"
SETTINGS = [
    "--preset", "so_arm100_reach_sb3",
    "--set", "training.num_envs=4", "--set", "training.num_steps=25", "--set", "training.num_epochs=1",
    "--set", "training.minibatch_size=100", "--set", "training.checkpoint_dir=runs",
    "--set", "training.run_name=stopped", "--set", "training.total_timesteps=1000000",
]  # fmt: skip


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signalled_run_saves_a_checkpoint_and_says_how_to_resume(tmp_path: Path, signum: int) -> None:
    environment = {**os.environ, KEY_ENV_VAR: str(tmp_path / "checkpoint.key")}
    process = subprocess.Popen(
        [str(JOSHUA), *SETTINGS],
        cwd=tmp_path,
        env=environment,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    watchdog = threading.Timer(120, process.kill)  # a run that never says it started fails, not hangs
    watchdog.start()
    for line in process.stdout:  # wait until training has started: the untrained checkpoint is written
        if line.startswith("sb3: training "):
            break
    process.send_signal(signum)
    stdout, stderr = process.communicate(timeout=120)
    watchdog.cancel()
    assert process.returncode == 128 + signum, stderr
    assert "Traceback" not in stderr and stderr.strip().endswith("joshua: interrupted")
    run_dir = tmp_path / "runs" / "stopped"
    stopped_at = checkpoint_step(run_checkpoints(run_dir.parent, run_dir.name)[-1])
    assert stopped_at > 0 and f"sb3: stopped at {stopped_at} steps; checkpoint runs/stopped_step_{stopped_at}" in stdout
    command = next(line for line in stdout.splitlines() if line.startswith("resume with: "))
    argv = shlex.split(command.removeprefix("resume with: "))
    assert argv[0] == "joshua" and argv[1:] == [*SETTINGS, "--set", "training.resume=true"]

    total = stopped_at + 100
    resumed = subprocess.run(
        [str(JOSHUA), *argv[1:], "--set", f"training.total_timesteps={total}"],
        cwd=tmp_path,
        env=environment,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert resumed.returncode == 0, resumed.stderr
    assert f"from stopped_step_{stopped_at} ({stopped_at} steps)" in resumed.stdout
    assert run_checkpoints(run_dir.parent, run_dir.name)[-1].name == f"stopped_step_{total}"
