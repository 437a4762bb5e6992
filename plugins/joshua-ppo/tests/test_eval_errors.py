"""`joshua eval` of a PPO run whose folders were tampered with: a stray empty checkpoint folder is skipped, a
corrupt config.json, a config whose hidden_sizes do not fit the saved network or a damaged params.msgpack is one
line, exit 2."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from joshua_core.errors import ConfigError
from joshua_ppo import train_mjx

pytestmark = pytest.mark.slow  # every test here trains

JOSHUA = [sys.executable, "-m", "joshua_core.cli"]
TINY = {  # 4 environments x 5 steps, one iteration; the checkpoint's files are the subject, not the physics: MuJoCo
    # Warp's, whose programs compile far sooner than MJX-JAX's, and episodes short enough for an eval to end at once
    "task": "ant_locomotion", "num_envs": 4, "num_steps": 5, "minibatch_size": 20, "num_epochs": 1,
    "mjx": {"impl": "WARP"}, "task_config": {"episode_length": 20},
    "total_timesteps": 20, "run_name": "tiny", "hidden_sizes": [16], "ppo": {"video_interval": -1},
}  # fmt: skip


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("ppo_eval")
    assert train_mjx(model_path="ant/ant_mjx.xml", config=TINY, checkpoint_dir=root) == root / "tiny_step_20"
    return root


def other_hidden_sizes(text: str, sizes: list[int]) -> str:
    """The config.json `text` with the run's training.hidden_sizes set to `sizes`."""
    document = json.loads(text)
    document["training"]["hidden_sizes"] = sizes
    return json.dumps(document)


def evaluate(target: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*JOSHUA, "eval", str(target), "--episodes", "2", "--no-video"], capture_output=True, text=True, timeout=300
    )


def test_an_empty_stray_checkpoint_folder_is_skipped(tiny_run: Path) -> None:
    stray = tiny_run / "tiny_step_500"
    stray.mkdir()
    try:
        done = evaluate(tiny_run / "tiny")
    finally:
        stray.rmdir()
    assert done.returncode == 0, done.stderr[-2000:]
    assert "evaluating" in done.stdout and "tiny_step_20 (20 steps)" in done.stdout


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda text: text[: len(text) // 2], "not valid JSON"),
        (lambda text: other_hidden_sizes(text, [32]), "hidden_sizes [32]"),
        (lambda text: other_hidden_sizes(text, [8, 16]), "hidden_sizes [8, 16]"),
    ],
    ids=["corrupt", "other-hidden-sizes", "other-layers"],
)
def test_a_damaged_checkpoint_config_is_one_line_exit_2(tiny_run: Path, tmp_path: Path, damage, message) -> None:
    checkpoint = tmp_path / "tiny_step_20"
    shutil.copytree(tiny_run / "tiny_step_20", checkpoint)
    config = checkpoint / "config.json"
    text = config.read_text()
    config.write_text(damage(text))
    assert config.read_text() != text
    done = evaluate(checkpoint)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr[-2000:]
    lines = done.stderr.strip().splitlines()
    assert lines[-1].startswith("joshua: error: ") and message in lines[-1], lines[-3:]


def test_a_damaged_params_file_is_one_line_exit_2(tiny_run: Path, tmp_path: Path) -> None:
    checkpoint = tmp_path / "tiny_step_20"
    shutil.copytree(tiny_run / "tiny_step_20", checkpoint)
    params = checkpoint / "params.msgpack"
    params.write_bytes(params.read_bytes()[: params.stat().st_size // 2])  # truncated
    done = evaluate(checkpoint)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr[-2000:]
    lines = done.stderr.strip().splitlines()
    assert lines[-1].startswith("joshua: error: cannot load ") and "params.msgpack" in lines[-1], lines[-3:]


def test_total_timesteps_below_one_iteration_is_refused(tmp_path: Path) -> None:
    config = {**TINY, "total_timesteps": 19, "ppo": {**TINY["ppo"], "unrolls_per_iteration": 1}}
    message = (
        "training.total_timesteps 19 is less than one iteration's environment steps, training.num_envs 4 x "
        "training.num_steps 5 = 20: set training.total_timesteps to at least 20"
    )
    with pytest.raises(ConfigError, match=re.escape(message)):
        train_mjx(model_path="ant/ant_mjx.xml", config=config, checkpoint_dir=tmp_path)
    assert not list(tmp_path.iterdir()), "a run folder was made"
