"""The two Isaac presets train from the `joshua` command (made tiny with --set), exit 0 and leave a checkpoint."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from joshua_core.runs import run_checkpoints
from joshua_sb3.run_folder import KEY_ENV_VAR, MODEL_FILE

pytestmark = pytest.mark.slow  # every test here trains

JOSHUA = Path(sys.executable).parent / "joshua"
PRESETS = ("isaac_ant_locomotion", "isaac_trileg")  # on models/isaac/ant.usd and trileg.usd, backend usd
TIMESTEPS = 2 * 16 * 2  # two PPO rollouts of 16 steps on 2 environments


@pytest.mark.parametrize("preset", PRESETS)
def test_preset_trains_from_the_cli_and_writes_a_checkpoint(preset: str, tmp_path: Path) -> None:
    process = subprocess.run(
        [
            str(JOSHUA), "--preset", preset,
            "--set", f"training.total_timesteps={TIMESTEPS}",
            "--set", "training.num_envs=2", "--set", "training.num_steps=16",
            "--set", "training.minibatch_size=32", "--set", "training.num_epochs=1",
            "--set", "training.checkpoint_dir=runs", "--set", "training.run_name=tiny",
        ],
        cwd=tmp_path,
        env={**os.environ, KEY_ENV_VAR: str(tmp_path / "checkpoint.key")},
        capture_output=True,
        text=True,
        timeout=300,
    )  # fmt: skip
    assert process.returncode == 0, process.stderr
    checkpoints = run_checkpoints(tmp_path / "runs", "tiny")
    assert checkpoints and (checkpoints[-1] / MODEL_FILE).is_file()
