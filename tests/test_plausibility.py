"""Implausible numbers on the command line and in configs are one line, exit 2, before any work: a NaN wait, a
1e9 Hz rate, a discount above 1, a 2e9-unit layer, an enum value the schema does not know, a preset chain
deeper than any real layering."""

from __future__ import annotations

from pathlib import Path

import pytest

from joshua_core import resources
from joshua_core.cli import main
from joshua_core.config import MAX_EXTENDS_DEPTH, load_preset
from joshua_core.errors import ConfigError
from joshua_core.options import LENIENT
from joshua_core.resources import DataFolder, models_dir

EXAMPLE = str(models_dir() / "trajectories" / "so_arm100_example.csv")


def one_line_usage_error(capsys: pytest.CaptureFixture[str], argv: list[str], message: str) -> None:
    """`joshua ARGV` exits 2 with one line on stderr holding `message`, and prints nothing else."""
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and message in captured.err, captured.err
    assert "Traceback" not in captured.err and captured.out == ""


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["mirror-replay", EXAMPLE, "--wait", "nan"], "--wait takes a number at least 0 and at most 3600, got 'nan'"),
        (["mirror-replay", EXAMPLE, "--rate", "1e9"], "--rate takes a number above 0 and at most 10000, got '1e9'"),
        (["mirror-replay", EXAMPLE, "--speed", "inf"], "--speed takes a number above 0"),
        (["mirror-replay", EXAMPLE, "--loops", "1.5"], "--loops takes an integer at least 1"),
        (["deploy", "policy", "--rate", "1e-9"], "--rate takes a number at least 1 and at most 10000, got '1e-9'"),
        (["deploy", "policy", "--rate", "1e9"], "--rate takes a number at least 1 and at most 10000, got '1e9'"),
        (["deploy", "policy", "--target", "1e300,0,0"], "--target takes three numbers X,Y,Z in metres within ±1000"),
        (["eval", "run", "--episodes", "1e20"], "--episodes takes an integer at least 1 and at most 100000"),
        (["lerobot-export", EXAMPLE, "--fps", "1e9"], "--fps takes an integer at least 1 and at most 1000, got '1e9'"),
        (["lerobot-export", EXAMPLE, "--height", "1"], "--height takes an integer at least 16 and at most 8192"),
        (["lerobot-export", EXAMPLE, "--width", "20000"], "--width takes an integer at least 16 and at most 8192"),
    ],
)
def test_an_implausible_command_line_number_is_one_line(
    capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    one_line_usage_error(capsys, argv, message)


@pytest.mark.parametrize(
    ("preset", "assignment", "message"),
    [
        ("sim_offscreen", "simulation.render_height=1", "render_height: must be 0 (the default) or at least 16, got 1"),
        (
            "sim_offscreen",
            "simulation.offscreen.fps=1e-9",
            "offscreen.fps: must be 0 (the default) or at least 1, got 1e-09",
        ),
        ("sim_offscreen", "simulation.offscreen.output=7", "offscreen.output: 7 is not one of MP4, PNG, MP4_AND_PNG"),
        ("so_arm100_reach_sb3", "training.gamma=2", "training.gamma: must be at most 1, got 2"),
        ("ant_train_mjx", "training.gae_lambda=2", "training.gae_lambda: must be at most 1, got 2"),
        ("ant_train_mjx", "training.hidden_sizes=[2000000000]", "hidden_sizes[0]: must be at most 65536"),
        ("so_arm100_reach_sb3", "training.hidden_sizes=[0]", "hidden_sizes[0]: must be at least 1, got 0"),
        ("ant_train_mjx", "training.ppo.distributed.num_processes=-1", "num_processes: must be at least 0, got -1"),
        ("sim_mirror", "simulation.mirror.stale_timeout=-1", "stale_timeout: must be at least 0, got -1"),
    ],
)
def test_an_implausible_config_number_is_one_line(
    capsys: pytest.CaptureFixture[str], preset: str, assignment: str, message: str
) -> None:
    one_line_usage_error(capsys, ["--preset", preset, "--set", assignment, "--print-config"], message)


def test_zero_still_means_the_default_where_a_bound_has_a_minimum(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["--preset", "sim_offscreen", "--set", "simulation.render_height=0", "--set", "simulation.offscreen.fps=0"]
    assert main([*argv, "--print-config"]) == 0, capsys.readouterr().err


def test_a_chain_of_extends_deeper_than_the_limit_is_one_line(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    depth = 1500  # beyond Python's recursion limit, which it used to hit
    presets = tmp_path / "presets"
    presets.mkdir()
    for index in range(depth):
        (presets / f"p{index}.pbtxt").write_text(f'extends: "p{index + 1}"\n')
    (presets / f"p{depth}.pbtxt").write_text('description: "the bottom"\n')
    monkeypatch.setattr(resources, "installed_folders", lambda: (DataFolder(tmp_path, "a test's data folder"),))
    with pytest.raises(ConfigError, match=f"extends a chain of more than {MAX_EXTENDS_DEPTH} presets"):
        load_preset("p0", LENIENT)
    assert load_preset(f"p{depth - MAX_EXTENDS_DEPTH + 1}", LENIENT).message.description == "the bottom"


def test_mirror_replay_refuses_a_column_naming_no_joint_of_the_model(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    csv = tmp_path / "motion.csv"
    csv.write_text(
        "timestamp,joint_1,joint_2,joint_3,joint_4,joint_5,joint_6,elbow\n0,0,0,0,0,0,0,0\n1,0,0,0,0,0,0,0\n"
    )
    one_line_usage_error(capsys, ["mirror-replay", str(csv)], f"{csv}:1: column 'elbow' is not a joint of the model")


def test_total_timesteps_below_one_sb3_iteration_is_one_line(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.chdir(tmp_path)  # the preset's checkpoint_dir is relative
    argv = ["--preset", "so_arm100_reach_sb3", "--set", "training.total_timesteps=64"]
    message = (
        "training.total_timesteps 64 is less than one iteration's environment steps, training.num_envs 32 x "
        "training.num_steps 50 = 1600: set training.total_timesteps to at least 1600"
    )
    one_line_usage_error(capsys, argv, message)
    one_line_usage_error(capsys, [*argv, "--set", "training.num_steps=0"], "x training.num_steps 64 = 2048")
    assert not list(tmp_path.rglob("*_ppo*")), "a run folder was made"
