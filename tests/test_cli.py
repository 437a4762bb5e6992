"""The `joshua` command end to end: exit codes, messages, the embedded default run and what it prints next."""

from __future__ import annotations

import json
from pathlib import Path

PRODUCT_PRESETS = {  # the nine presets shipped from the start (docs/presets.md); more come on top
    "so_arm100_sim_interactive", "sim_passive", "sim_offscreen", "sim_mirror", "so_arm100_train_mjx",
    "so_arm100_pick_place_mjx", "ant_train_mjx", "isaac_ant_locomotion", "isaac_trileg",
}  # fmt: skip


def test_presets_lists_the_shipped_ones_with_descriptions(run_joshua) -> None:
    result = run_joshua("presets")
    assert result.returncode == 0
    names = [line.split()[0] for line in result.stdout.splitlines()]
    assert PRODUCT_PRESETS <= set(names) and "so_arm100_reach_sb3" in names and len(names) == len(set(names))
    assert all(len(line.split(maxsplit=1)) == 2 for line in result.stdout.splitlines())


def test_plugins_lists_the_mujoco_backend_and_the_builtin_mode(run_joshua) -> None:
    result = run_joshua("plugins")
    assert result.returncode == 0
    assert "mujoco  (joshua-mujoco 0.1.0)" in result.stdout
    assert "backend  mujoco" in result.stdout and "mode     HEADLESS" in result.stdout


def test_unknown_preset_exits_2_with_suggestions(run_joshua) -> None:
    result = run_joshua("--preset", "no_such")
    assert result.returncode == 2
    assert "unknown preset 'no_such'" in result.stderr and "Available presets:" in result.stderr
    close = run_joshua("--preset", "sim_pasive")
    assert close.returncode == 2 and "Did you mean: sim_passive" in close.stderr
    assert "Traceback" not in result.stderr + close.stderr


def test_config_parse_error_exits_2_with_location(run_joshua, tmp_path: Path) -> None:
    config = tmp_path / "run.pbtxt"
    config.write_text("simulation {\n  mode: HEADLESS\n  model_path: so_arm100/scene.xml\n}\n")
    result = run_joshua("--config", str(config))
    assert result.returncode == 2
    assert f"{config}:3:15:" in result.stderr and "Traceback" not in result.stderr


def test_missing_mode_plugin_says_what_to_install(run_joshua) -> None:
    result = run_joshua("--preset", "sim_passive", env={"JOSHUA_DISABLE_PLUGINS": "modes"})  # setup.sh installs it
    assert result.returncode == 2
    assert "no mode named 'PASSIVE' is installed. It comes from joshua-modes, which is disabled by" in result.stderr
    training = run_joshua("--preset", "ant_train_mjx", env={"JOSHUA_DISABLE_PLUGINS": "mjx,ppo"})
    assert training.returncode == 2
    for distribution in ("joshua-ppo", "joshua-mjx"):
        assert f"It comes from {distribution}, which is disabled by" in training.stderr, training.stderr


def test_missing_model_exits_2_naming_the_paths(run_joshua, tmp_path: Path) -> None:
    result = run_joshua("--set", "simulation.model_path=robots/absent.xml")
    assert result.returncode == 2
    assert str(tmp_path / "robots" / "absent.xml") in result.stderr


def test_bad_override_exits_2(run_joshua) -> None:
    result = run_joshua("--set", "simulation.duraton=3")
    assert result.returncode == 2 and "Did you mean: duration" in result.stderr


def test_print_config_shows_resolved_paths(run_joshua) -> None:
    result = run_joshua("--preset", "sim_passive", "--print-config")
    assert result.returncode == 0
    assert 'model_path: "/' in result.stdout and "so_arm100/scene.xml" in result.stdout


HEADLESS = ("--set", "simulation.mode=HEADLESS")  # the embedded default's model as a quick physics run


def test_default_run_validates_and_records_the_example_and_says_what_next(run_joshua, tmp_path: Path) -> None:
    result = run_joshua(env={"DISPLAY": ""})  # exactly what a newcomer types after ./setup.sh, no display
    assert result.returncode == 0, result.stderr
    output = tmp_path / "joshua_output"
    report = json.loads((output / "passive_report.json").read_text())
    assert report["ok"] and report["trajectory"].endswith("so_arm100_example.csv"), report
    video = (output / "passive_replay.mp4").read_bytes()
    assert video[4:8] == b"ftyp" and len(video) > 10_000
    for printed in ("validation report: joshua_output/passive_report.json", "video: joshua_output/passive_replay.mp4"):
        assert printed in result.stdout, result.stdout
    steps = result.stdout[result.stdout.index("next:") :]
    for command in ("--preset sim_passive", "--preset so_arm100_sim_interactive", "_sb3", "joshua presets"):
        assert command in steps
    assert report["replayed_rows"] == report["rows"] > 0


def test_default_run_without_joshua_modes_says_to_install_it(run_joshua) -> None:
    result = run_joshua(env={"JOSHUA_DISABLE_PLUGINS": "modes"})
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "no mode named 'PASSIVE' is installed. It comes from joshua-modes" in result.stderr


def test_headless_run_steps_the_arm_and_writes_a_summary(run_joshua, tmp_path: Path) -> None:
    result = run_joshua(*HEADLESS, "--set", "simulation.keyframe=home", "--set", "simulation.duration=2")
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "joshua_output" / "headless_summary.json").read_text())
    assert summary["sim_seconds"] >= 2.0 and summary["steps"] > 0
    assert summary["realtime_factor"] > 0 and summary["keyframe"] == "home"
    assert summary["max_qpos_drift"] < 1e-3  # held at home by its actuators
    assert "real time" in result.stdout


def test_diverging_model_is_a_runtime_failure(run_joshua, tmp_path: Path) -> None:
    model = tmp_path / "unstable.xml"
    model.write_text(
        '<mujoco><option timestep="0.5"/><worldbody><body><joint type="slide" stiffness="1e9"/>'
        '<geom size="0.1" mass="1e-6"/></body></worldbody>'
        '<keyframe><key name="start" qpos="1"/></keyframe></mujoco>'
    )
    result = run_joshua(*HEADLESS, "--set", f"simulation.model_path={model}", "--set", "simulation.keyframe=start")
    assert result.returncode == 1
    assert "simulation diverged" in result.stderr


def test_unknown_keyframe_is_a_config_error(run_joshua) -> None:
    result = run_joshua(*HEADLESS, "--set", "simulation.keyframe=nope")
    assert result.returncode == 2
    assert "simulation.keyframe: no keyframe 'nope' in the model; keyframes: home" in result.stderr
    assert "Traceback" not in result.stderr


def test_missing_plugin_is_reported_before_missing_files(run_joshua) -> None:
    result = run_joshua(
        "--preset", "sim_passive", "--set", "simulation.trajectory_path=absent.csv",
        env={"JOSHUA_DISABLE_PLUGINS": "modes"},
    )  # fmt: skip
    assert result.returncode == 2
    assert "joshua-modes" in result.stderr and "absent.csv" not in result.stderr


def test_known_command_of_a_missing_plugin_says_what_to_install(run_joshua) -> None:
    result = run_joshua("mirror-replay", "motion.csv", env={"JOSHUA_DISABLE_PLUGINS": "joshua-mirror"})
    assert result.returncode == 2
    assert "no command named 'mirror-replay' is installed. It comes from joshua-mirror" in result.stderr
    assert "Traceback" not in result.stderr


def test_options_set_on_the_command_line_print_by_short_name_and_read_back(run_joshua, tmp_path: Path) -> None:
    printed = run_joshua(
        "--preset", "sim_passive", "--strict", "--print-config",
        "--set", "simulation.viewer.fps=12", "--set", "simulation.offscreen.fps=60",
    )  # fmt: skip
    assert printed.returncode == 0, printed.stderr
    assert "  mode: PASSIVE\n" in printed.stdout and "[" not in printed.stdout
    for block in ("offscreen {\n    fps: 60.0\n  }", "replay {\n    strict: true\n  }", "viewer {\n    fps: 12.0\n  }"):
        assert block in printed.stdout
    (tmp_path / "printed.pbtxt").write_text(printed.stdout)
    again = run_joshua("--config", "printed.pbtxt", "--print-config")
    assert again.returncode == 0 and again.stdout == printed.stdout


def test_episode_is_the_replay_episode_option(run_joshua) -> None:
    printed = run_joshua("--preset", "sim_passive", "--episode", "3", "--print-config")
    assert printed.returncode == 0, printed.stderr
    assert "replay {\n    episode: 3\n" in printed.stdout
    negative = run_joshua("--preset", "sim_passive", "--episode", "-1")
    assert negative.returncode == 2 and negative.stderr.strip() == "joshua: error: --episode must be 0 or more (got -1)"


def test_bad_option_names_list_the_close_ones(run_joshua, tmp_path: Path) -> None:
    result = run_joshua("--preset", "sim_offscreen", "--set", "simulation.offscren.fps=3")
    assert result.returncode == 2 and "Did you mean: offscreen?" in result.stderr
    config = tmp_path / "run.pbtxt"
    config.write_text('extends: "sim_offscreen"\nsimulation { offscreen { fsp: 30 } }\n')
    located = run_joshua("--config", str(config))
    assert located.returncode == 2 and f"{config}:2:26: " in located.stderr and "Did you mean: fps?" in located.stderr


def test_a_config_of_a_missing_mode_plugin_says_what_to_install_before_its_options(run_joshua, tmp_path: Path) -> None:
    config = tmp_path / "run.pbtxt"
    config.write_text('extends: "sim_offscreen"\nsimulation { offscreen { fps: 30 } }\n')
    disabled = {"JOSHUA_DISABLE_PLUGINS": "modes,ppo"}
    for args in (("--config", str(config)), ("--config", str(config), "--print-config"), ("--preset", "sim_offscreen")):
        result = run_joshua(*args, "--set", "simulation.offscreen.fps=60", env=disabled)
        assert result.returncode == 2, args
        assert "no mode named 'OFFSCREEN' is installed. It comes from joshua-modes" in result.stderr, result.stderr
    training = run_joshua("--preset", "ant_train_mjx_tuned", "--set", "training.entropy_coef=0", env=disabled)
    assert training.returncode == 2 and "It comes from joshua-ppo, which is disabled" in training.stderr
    headless = run_joshua(*HEADLESS, "--set", "simulation.offscreen.fps=60", env=disabled)  # needs no joshua-modes
    assert headless.returncode == 2 and "is an option of joshua-modes" in headless.stderr, headless.stderr
    presets = run_joshua("presets", env={"JOSHUA_DISABLE_PLUGINS": "modes,mirror,ppo,sb3"})
    assert presets.returncode == 0 and "ant_train_mjx_tuned " in presets.stdout and "sim_offscreen " in presets.stdout


def _one_line_error(result, expected: str) -> None:
    """Exit 2 with `expected` on the single `joshua: error:` line, and no traceback."""
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    lines = [line for line in result.stderr.splitlines() if line.startswith("joshua: error: ")]
    assert len(lines) == 1 and expected in lines[0], result.stderr


def test_non_finite_and_huge_numbers_exit_2_before_running(run_joshua, tmp_path: Path) -> None:
    cases = [
        (("--set", "simulation.duration=nan"), "embedded default: simulation.duration: must be finite, got nan"),
        (("--set", "simulation.duration=inf"), "simulation.duration: must be finite, got inf"),
        (("--preset", "sim_offscreen", "--set", "simulation.offscreen.fps=nan"), "offscreen.fps: must be finite"),
        (("--preset", "sim_passive", "--set", "simulation.replay.speed=nan"), "replay.speed: must be finite"),
        (("--preset", "ant_train_mjx", "--set", "training.learning_rate=nan"), "learning_rate: must be finite"),
        (("--preset", "sim_offscreen", "--set", "simulation.offscreen.fps=1e9"), "fps: must be at most 1000, got 1e+"),
        (
            ("--preset", "sim_offscreen", "--set", "simulation.render_width=100000"),
            "simulation.render_width: must be at most 8192, got 100000",
        ),
        (
            ("mirror-replay", "--rate", "nan", "motion.csv"),
            "--rate takes a number above 0 and at most 10000, got 'nan'",
        ),
    ]
    for args, expected in cases:
        _one_line_error(run_joshua(*args), expected)
    assert not (tmp_path / "joshua_output").exists()  # nothing ran


def test_bad_config_files_and_modes_exit_2_in_one_line(run_joshua, tmp_path: Path) -> None:
    binary = tmp_path / "blob.pbtxt"
    binary.write_bytes(bytes(range(256)))
    _one_line_error(run_joshua("--config", str(binary)), "blob.pbtxt: not a text config (byte 128 is not UTF-8)")
    _one_line_error(run_joshua("--config", str(tmp_path)), f"config file '{tmp_path}' is a directory")
    mode = run_joshua("--set", "simulation.mode=99")
    _one_line_error(mode, "no mode named '99' is installed. Installed modes: HEADLESS, INTERACTIVE")


def test_an_output_dir_that_is_a_file_or_cannot_be_made_exits_2(run_joshua, tmp_path: Path) -> None:
    (tmp_path / "taken").write_text("a file, not a folder\n")
    result = run_joshua("--set", "simulation.output_dir=taken")
    _one_line_error(result, "simulation.output_dir 'taken' is a file, not a folder")
    below = run_joshua("--set", "simulation.output_dir=taken/runs")
    _one_line_error(below, "simulation.output_dir 'taken/runs' cannot be created: Not a directory")
    assert (tmp_path / "taken").read_text() == "a file, not a folder\n"


def test_an_item_of_a_list_of_numbers_is_set_by_index(run_joshua) -> None:
    result = run_joshua("--preset", "so_arm100_reach_sb3", "--set", "training.hidden_sizes[1]=8", "--print-config")
    assert result.returncode == 0, result.stderr
    sizes = [line.split(":")[1].strip() for line in result.stdout.splitlines() if "hidden_sizes:" in line]
    assert sizes[1] == "8" and len(sizes) == 2


def test_file_system_failures_exit_2_in_one_line_naming_the_path(run_joshua, tmp_path: Path) -> None:
    long = "x" * 300
    for output_dir in (long, f"out/{long}"):  # a name too long to look up, and to make
        result = run_joshua("--set", f"simulation.output_dir={output_dir}")
        assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
        assert output_dir in result.stderr and "File name too long" in result.stderr
    config = tmp_path / "nul.pbtxt"
    config.write_text('extends: "sim_offscreen"\nsimulation { output_dir: "out\\000x" }\n')
    result = run_joshua("--config", str(config))
    assert result.returncode == 2 and result.stderr.count("\n") == 1 and "NUL byte" in result.stderr, result.stderr


def test_an_os_error_anywhere_becomes_a_usage_error_with_its_path() -> None:
    import errno

    import pytest

    from joshua_core.cli import os_errors_reported
    from joshua_core.errors import UsageError

    def full() -> int:
        raise OSError(errno.ENOSPC, "No space left on device", "/data/run/model.zip")

    def read_only() -> int:
        raise OSError(errno.EROFS, "Read-only file system", "/ro/.x.tmp", None, "/ro/x")

    def other() -> int:
        raise ValueError("not about paths")

    with pytest.raises(UsageError, match="^/data/run/model.zip: No space left on device$"):
        os_errors_reported(full)
    with pytest.raises(UsageError, match="^/ro/.x.tmp -> /ro/x: Read-only file system$"):
        os_errors_reported(read_only)
    with pytest.raises(ValueError, match="not about paths"):  # a bug stays a traceback
        os_errors_reported(other)
