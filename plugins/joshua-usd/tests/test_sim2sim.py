"""`joshua usd eval RUN --physics MUJOCO,PHYSX`: one trained SB3 policy rolled out on MuJoCo and on CPU PhysX,
return with 95 % intervals side by side in one table and a JSON; bad input is one line, exit 2."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from joshua_core.cli import main
from joshua_core.interfaces import EpisodeResults
from joshua_core.statistics import summarize
from joshua_sb3.run_folder import KEY_ENV_VAR
from joshua_usd.physx import PHYSX_NOT_LOADING
from joshua_usd.sim2sim import RESULTS_FILE, table_lines

JOSHUA = Path(sys.executable).parent / "joshua"
EPISODE_LENGTH = 40  # steps: short episodes keep the PhysX rollout to seconds
EPISODES = 3
RESULT_LINE_TOLERANCE = 1e-3  # `joshua eval` prints 6 significant digits; returns here are tens


def joshua(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """Run `joshua ARGS` with a checkpoint key of its own (not the user's)."""
    environment = {**os.environ, KEY_ENV_VAR: str(cwd / "checkpoint.key")}
    return subprocess.run([str(JOSHUA), *args], cwd=cwd, env=environment, capture_output=True, text=True, timeout=600)


@pytest.mark.slow
def test_one_sb3_policy_on_mujoco_and_physx(tmp_path: Path) -> None:
    pytest.importorskip("ovphysx")
    trained = joshua(
        "--preset", "isaac_trileg",
        "--set", "training.total_timesteps=64",
        "--set", "training.num_envs=2",
        "--set", "training.num_steps=32",
        "--set", "training.minibatch_size=64",
        "--set", f"training.task_config.episode_length={EPISODE_LENGTH}",
        "--set", "training.checkpoint_dir=runs",
        "--set", "training.run_name=tiny",
        cwd=tmp_path,
    )  # fmt: skip
    assert trained.returncode == 0, trained.stderr
    run_dir = tmp_path / "runs" / "tiny"
    episodes = ("--episodes", str(EPISODES))
    compared = joshua("usd", "eval", str(run_dir), "--physics", "mujoco, PHYSX", *episodes, cwd=tmp_path)
    assert compared.returncode == 0, compared.stderr
    table = compared.stdout.splitlines()
    header = next(i for i, line in enumerate(table) if line.startswith("physics"))
    assert header > table.index("PHYSX:") > table.index("MUJOCO:")  # the rollouts in order, then one table
    assert [line.split()[:2] for line in table[header + 1 : header + 3]] == [["MUJOCO", "3"], ["PHYSX", "3"]]
    results = json.loads((run_dir / RESULTS_FILE).read_text())["physics"]
    assert list(results) == ["MUJOCO", "PHYSX"]
    for summary in results.values():
        low, high = summary["mean_return_ci95"]
        assert summary["episodes"] == EPISODES and low <= summary["mean_return"] <= high
        assert 0 < summary["mean_length"] <= EPISODE_LENGTH
    # MUJOCO is what `joshua eval` rolls out for a run trained on the usd backend: the same episodes
    plain = joshua("eval", str(run_dir), "--no-video", *episodes, cwd=tmp_path)
    assert plain.returncode == 0, plain.stderr
    mean_return = next(float(line.split()[1]) for line in plain.stdout.splitlines() if line.startswith("mean_return:"))
    assert abs(mean_return - results["MUJOCO"]["mean_return"]) <= RESULT_LINE_TOLERANCE * abs(mean_return)


@pytest.mark.parametrize(
    ("physics", "message"),
    [
        ("MUJOCO,BULLET", "--physics: unknown physics 'BULLET'; choose from MUJOCO, PHYSX"),
        (" , ", "--physics: name one or more of MUJOCO, PHYSX (comma-separated)"),
        ("PHYSX", "backend usd, physics PHYSX: needs NVIDIA's ovphysx, which is not installed; "),
    ],
)
def test_bad_physics_is_one_line_exit_2(
    physics: str, message: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "ovphysx", None)  # as if the physx extra were not installed
    assert main(["usd", "eval", str(tmp_path), "--physics", physics]) == 2
    error = capsys.readouterr().err
    assert error.startswith(f"joshua: error: {message}") and error.count("\n") == 1, error
    assert not (tmp_path / RESULTS_FILE).exists()


# builds the Isaac Ant's PhysX environments through the usd backend; prints the ConfigError's message
BUILD_PHYSX_ENVS = """
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.interfaces import EnvKind, EnvSpec
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_usd.options_pb2 import UsdOptions, usd
training = TrainingConfig()
training.Extensions[usd].physics = UsdOptions.PHYSX
spec = EnvSpec("isaac_ant_locomotion", 2, model_path=resolve_data_path("isaac/ant.usd"), training=training)
plugins = PluginHost.discover()
try:
    plugins.backend("usd").create_envs(spec, EnvKind.NUMPY, plugins)
except ConfigError as error:
    print(error)
"""


def test_physx_whose_native_library_does_not_load_is_a_config_error(tmp_path: Path) -> None:
    # a fresh process, so that ovphysx is imported anew, with its library pointed at a file that is not there
    broken = dict(os.environ, OVPHYSX_LIB=str(tmp_path / "missing" / "libovphysx.so"))
    result = subprocess.run(
        [sys.executable, "-c", BUILD_PHYSX_ENVS], env=broken, capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith(f"{PHYSX_NOT_LOADING}: Failed to load OVPHYSX_LIB="), result.stdout
    assert result.stdout.count("\n") == 1  # one line, which the CLI reports with exit 2


def test_the_table_shows_success_where_the_task_has_it() -> None:
    with_success = summarize(EpisodeResults([1.0, 3.0], [10, 10], {"success": [1.0, 0.0]}))
    without = summarize(EpisodeResults([2.0], [5], {}))
    header, first, second = table_lines({"MUJOCO": with_success, "PHYSX": without})
    assert header.split("  ")[-2:] == ["success", "95 % interval"]
    # mean 2 of returns 1 and 3: t(1 df) 12.71 x std 1.414 / sqrt 2 = 12.71 either side
    assert first.split()[:7] == ["MUJOCO", "2", "10.0", "2", "[-10.71,", "14.71]", "0.500"]
    assert second.split()[:4] == ["PHYSX", "1", "5.0", "2"] and second.split()[-2:] == ["-", "-"]
    assert "- (one episode)" in second
