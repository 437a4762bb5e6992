"""Config schema, presets, `extends`, `--set` overrides and path resolution."""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

import joshua_sample_plugin
import pytest

from joshua_core import config as config_module
from joshua_core import resources
from joshua_core.config import (
    apply_override,
    config_text_of,
    finalize,
    load_file,
    load_preset,
    parse_text,
    preset_names,
    simulation_mode,
)
from joshua_core.config_pb2 import JoshuaConfig, SimulationConfig, TrainingConfig
from joshua_core.errors import ConfigError, ModelError, UsageError
from joshua_core.options import LENIENT, OptionSet, message_to_dict, options_of, parse_dict
from joshua_core.plugins import PluginHost, PluginInfo
from joshua_core.resources import DataFolder, models_dir
from joshua_mirror import options_pb2 as mirror_options
from joshua_modes import options_pb2 as modes_options
from joshua_ppo import options_pb2 as ppo_options

OPTIONS = PluginHost.discover().options()  # the installed plugins' options, which the presets use

REPO_ROOT = Path(__file__).resolve().parents[1]


def mappings_of(simulation: SimulationConfig):
    """The mirror's mappings in a simulation config (joshua-mirror's option)."""
    return options_of(simulation, mirror_options.mirror_topic_mappings).mappings


SEED_PRESETS = {
    "so_arm100_sim_interactive",
    "sim_passive",
    "sim_mirror",
    "ant_train_mjx",
    "so_arm100_train_mjx",
    "so_arm100_pick_place_mjx",
    "isaac_ant_locomotion",
    "isaac_trileg",
}


def test_committed_generated_code_matches_every_schema(tmp_path: Path, monkeypatch) -> None:
    spec = importlib.util.spec_from_file_location("joshua_proto_generate", REPO_ROOT / "proto" / "generate.py")
    generate = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, generate)  # its dataclasses look their module up
    spec.loader.exec_module(generate)
    assert len(generate.SCHEMAS) == 8  # the core's, six plugins' options, the joshua-rk4 example's
    for index, schema in enumerate(generate.SCHEMAS):
        for fresh in generate.generate(schema, tmp_path / str(index)):
            committed = schema.out_dir / fresh.name
            assert committed.read_bytes() == fresh.read_bytes(), f"{committed} is stale: run python proto/generate.py"


def test_simulation_config_keeps_the_seed_field_numbers() -> None:
    fields = {f.name: f.number for f in SimulationConfig.DESCRIPTOR.fields}
    assert {k: fields[k] for k in ("mode", "model_path", "trajectory_path")} == {
        "mode": 1,
        "model_path": 2,
        "trajectory_path": 3,
    }
    assert 4 not in fields.values()  # mirror_topic_mappings, now joshua-mirror's option: never reused
    assert (fields["render_width"], fields["render_height"]) == (5, 6)
    assert (
        SimulationConfig.DESCRIPTOR.fields_by_name["mode"].type
        == SimulationConfig.DESCRIPTOR.fields_by_name["model_path"].type
    )  # a string: plugins add modes by name


def test_the_seed_mode_names_parse_bare_or_quoted_and_empty_means_interactive(tmp_path: Path) -> None:
    for mode in ("INTERACTIVE", "PASSIVE", "MIRROR", "OFFSCREEN", "HEADLESS"):
        for written in (mode, f'"{mode}"'):
            (tmp_path / "run.pbtxt").write_text(f"operation_mode: SIMULATION\nsimulation {{ mode: {written} }}\n")
            assert load_file(tmp_path / "run.pbtxt", OPTIONS).message.simulation.mode == mode
    assert simulation_mode(SimulationConfig()) == "INTERACTIVE"
    assert finalize(load_preset("so_arm100_sim_interactive", OPTIONS)).simulation.mode == "INTERACTIVE"


PLUGIN_PRESETS = {
    "so_arm100_reach_sb3",
    "ant_train_mjx_tuned",
    "trileg_train_mjx",
    "isaac_ant_mjx",
    "so_arm100_pick_place_mjx_dr",
    "so_arm100_pick_place_pixels",
    *(f"so101_{name}" for name in ("sim_interactive", "sim_mirror", "reach_sb3", "train_mjx", "pick_place_mjx")),
    *(f"so101_pick_place_{name}" for name in ("mjx_dr", "pixels")),
}  # presets added with the plugins, beyond the first nine; the SO-101's extend the SO-ARM100's


def test_the_shipped_presets_each_parse_with_a_description() -> None:
    assert set(preset_names()) == SEED_PRESETS | {"sim_offscreen"} | PLUGIN_PRESETS
    for name in preset_names():
        loaded = load_preset(name, OPTIONS)
        assert loaded.message.description, name
        assert "\n" not in loaded.message.description
        finalize(loaded)  # every model and trajectory a preset names exists


def test_preset_model_paths_resolve_against_shipped_models_from_any_cwd(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    config = finalize(load_preset("sim_passive", OPTIONS))
    assert Path(config.simulation.model_path) == (models_dir() / "so_arm100" / "scene.xml").resolve()
    assert Path(config.simulation.trajectory_path).is_file()


def test_mirror_preset_carries_the_seed_offsets() -> None:
    mappings = mappings_of(load_preset("sim_mirror", OPTIONS).message.simulation)
    assert [(m.ros_topic, m.mujoco_actuator) for m in mappings] == [
        (f"/encoder/joint_{i}", f"joint_{i}_position") for i in range(1, 7)
    ]
    assert [round(m.offset, 6) for m in mappings] == [0.0, -0.087, 0.052, 0.0, -0.034, 0.0]


def test_parse_error_reports_file_line_and_column(tmp_path: Path) -> None:
    bad = tmp_path / "bad.pbtxt"
    bad.write_text('operation_mode: SIMULATION\nsimulation {\n  mode: PASSIVE\n  modl_path: "x.xml"\n}\n')
    with pytest.raises(ConfigError, match=rf"{bad}:4:3: .*modl_path"):
        load_file(bad, OPTIONS)


def test_bad_enum_value_is_a_located_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.pbtxt"
    bad.write_text("operation_mode: SIDEWAYS\n")
    with pytest.raises(ConfigError, match=rf"{bad}:1:17: .*SIDEWAYS"):
        load_file(bad, OPTIONS)


def test_custom_file_extends_a_preset_and_replaces_its_lists(tmp_path: Path) -> None:
    custom = tmp_path / "lab.pbtxt"
    custom.write_text(
        'extends: "sim_mirror"\n'
        "simulation {\n"
        "  render_width: 320\n"
        "  mirror_topic_mappings {\n"
        '    mappings { ros_topic: "/arm/j1" mujoco_actuator: "joint_1_position" offset: 0.5 }\n'
        "  }\n"
        "}\n"
    )
    message = load_file(custom, OPTIONS).message
    assert message.simulation.mode == "MIRROR"  # from the preset
    assert message.simulation.model_path == "so_arm100/scene.xml"  # from the preset
    assert message.simulation.render_width == 320  # from the file
    assert [m.ros_topic for m in mappings_of(message.simulation)] == ["/arm/j1"]


def test_extends_of_an_unknown_preset_suggests_close_names(tmp_path: Path) -> None:
    custom = tmp_path / "lab.pbtxt"
    custom.write_text('extends: "sim_pasive"\n')
    with pytest.raises(UsageError, match="Did you mean: sim_passive"):
        load_file(custom, OPTIONS)


def test_extends_cycle_is_reported(tmp_path: Path, monkeypatch) -> None:
    (tmp_path / "presets").mkdir()
    (tmp_path / "presets" / "a.pbtxt").write_text('extends: "b"\n')
    (tmp_path / "presets" / "b.pbtxt").write_text('extends: "a"\n')
    monkeypatch.setattr(resources, "installed_folders", lambda: (DataFolder(tmp_path, "a test's data folder"),))
    with pytest.raises(ConfigError, match="cycle: a -> b -> a"):
        load_preset("a", OPTIONS)


def test_overrides_set_scalars_enums_strings_and_list_items() -> None:
    config = load_preset("sim_mirror", OPTIONS).message
    apply_override(config, "simulation.render_width=1280", OPTIONS)
    apply_override(config, "simulation.mode=OFFSCREEN", OPTIONS)
    apply_override(config, "simulation.keyframe=home", OPTIONS)
    apply_override(config, "simulation.mirror_topic_mappings.mappings[1].offset=0.25", OPTIONS)
    apply_override(config, "simulation.mirror_topic_mappings.mappings[6].ros_topic=/encoder/extra", OPTIONS)
    assert config.simulation.render_width == 1280
    assert config.simulation.mode == "OFFSCREEN"
    assert config.simulation.keyframe == "home"
    mappings = mappings_of(config.simulation)
    assert mappings[1].offset == pytest.approx(0.25)
    assert len(mappings) == 7 and mappings[6].ros_topic == "/encoder/extra"


@pytest.mark.parametrize(
    ("assignment", "message"),
    [
        ("simulation.render_widht=3", "Did you mean: render_width"),
        ("simulation.render_width=wide", "render_width"),
        ("simulation.duration=long", "duration"),
        ("simulation=3", "is a message"),
        ("simulation.mirror_topic_mappings.mappings[9].offset=1", "has 6 items"),
        ("simulation.mirror_topic_mappings.mappings.offset=1", "is a list"),
        ("no_equals_sign", "path.to.field=value"),
    ],
)
def test_bad_overrides_say_what_is_wrong(assignment: str, message: str) -> None:
    with pytest.raises(UsageError, match=message):
        apply_override(load_preset("sim_mirror", OPTIONS).message, assignment, OPTIONS)


def test_training_defaults_fill_the_trainer_and_backend() -> None:
    mjx = finalize(load_preset("ant_train_mjx", OPTIONS)).training
    assert (mjx.trainer, mjx.backend) == ("ppo", "mjx")
    assert (mjx.num_envs, mjx.num_steps, mjx.num_epochs, mjx.minibatch_size) == (2048, 10, 4, 256)
    assert (mjx.learning_rate, mjx.gamma, mjx.clip_epsilon) == pytest.approx((3e-4, 0.99, 0.2))
    isaac = finalize(load_preset("isaac_trileg", OPTIONS)).training
    assert (isaac.trainer, isaac.backend) == ("sb3", "usd")


def test_missing_model_names_every_path_searched(tmp_path: Path) -> None:
    custom = tmp_path / "run.pbtxt"
    custom.write_text('simulation { mode: HEADLESS model_path: "robots/nowhere.xml" }\n')
    with pytest.raises(ModelError) as caught:
        finalize(load_file(custom, OPTIONS))
    text = str(caught.value)
    assert str(tmp_path / "robots" / "nowhere.xml") in text
    assert str(models_dir() / "robots" / "nowhere.xml") in text


def test_relative_model_path_in_a_custom_file_resolves_beside_it(tmp_path: Path) -> None:
    (tmp_path / "robot.xml").write_text("<mujoco/>")
    custom = tmp_path / "run.pbtxt"
    custom.write_text('simulation { mode: HEADLESS model_path: "robot.xml" }\n')
    assert finalize(load_file(custom, OPTIONS)).simulation.model_path == str(tmp_path / "robot.xml")


def test_negative_sizes_are_rejected() -> None:
    loaded = load_preset("sim_offscreen", OPTIONS)
    apply_override(loaded.message, "simulation.render_width=-5", OPTIONS)
    with pytest.raises(
        ConfigError, match="simulation.render_width: must be 0 \\(the default\\) or at least 16, got -5"
    ):
        finalize(loaded)


def test_default_config_validates_and_records_the_example_trajectory() -> None:
    config = finalize(config_module.load_default(OPTIONS))
    assert config.operation_mode == JoshuaConfig.SIMULATION
    assert config.simulation.mode == "PASSIVE" and config.simulation.trajectory_path.endswith("so_arm100_example.csv")
    assert "display: RECORD" in config_module.DEFAULT_CONFIG_TEXT  # a video, never a window: also with a display


def test_extends_is_applied_and_cannot_be_set_from_the_command_line(tmp_path: Path) -> None:
    custom = tmp_path / "lab.pbtxt"
    custom.write_text('extends: "sim_passive"\n')
    assert load_file(custom, OPTIONS).message.extends == ""
    with pytest.raises(UsageError, match="extends"):
        apply_override(load_preset("sim_passive", OPTIONS).message, "extends=sim_mirror", OPTIONS)


def test_negative_hyper_parameters_are_rejected() -> None:
    loaded = load_preset("ant_train_mjx", OPTIONS)
    apply_override(loaded.message, "training.learning_rate=-0.1", OPTIONS)
    with pytest.raises(ConfigError, match="training.learning_rate: must be at least 0"):
        finalize(loaded)


# Plugins' options: extensions of the config messages, read and written by their short names.


def test_every_preset_parses_strictly_and_prints_as_it_reads(tmp_path: Path) -> None:
    options = OPTIONS
    for name in preset_names():
        config = finalize(load_preset(name, options))
        printed = config_text_of(config, options)
        assert "[joshua" not in printed, name  # options by their short names
        reparsed = parse_text(printed, f"printed {name}", options)
        assert reparsed == config, name
    tuned = config_text_of(finalize(load_preset("ant_train_mjx_tuned", options)), options)
    assert "\n  ppo {\n" in tuned and "advantage: LAMBDA_RETURN" in tuned
    assert "\n  mode: MIRROR\n" in config_text_of(finalize(load_preset("sim_mirror", options)), options)


def test_options_read_by_short_name_or_bracketed(tmp_path: Path) -> None:
    custom = tmp_path / "run.pbtxt"
    custom.write_text(
        'extends: "sim_offscreen"\n'
        "simulation {\n"
        "  offscreen { fps: 12 output: PNG shadows: false }  # a comment\n"
        "  [joshua_modes.replay] { speed: 2 }\n"
        "  viewer: < camera: 'side' >\n"
        "}\n"
    )
    simulation = load_file(custom, OPTIONS).message.simulation
    offscreen = options_of(simulation, modes_options.offscreen)
    assert (offscreen.fps, offscreen.output) == (12, modes_options.OffscreenOptions.PNG)
    assert offscreen.HasField("shadows") and not offscreen.shadows
    assert options_of(simulation, modes_options.replay).speed == 2
    assert options_of(simulation, modes_options.viewer).camera == "side"
    assert simulation.trajectory_path.endswith("so_arm100_example.csv")  # from the preset


def test_extends_merges_options_and_replaces_their_lists(tmp_path: Path) -> None:
    custom = tmp_path / "tuned.pbtxt"
    custom.write_text('extends: "ant_train_mjx_tuned"\ntraining { hidden_sizes: [32] entropy_coef: 0 }\n')
    training = load_file(custom, OPTIONS).message.training
    ppo = options_of(training, ppo_options.ppo)
    assert list(training.hidden_sizes) == [32]  # the file's list replaces the preset's
    assert list(ppo.value_hidden_sizes) == [256] * 5 and ppo.squash_actions  # the rest from the preset
    assert training.entropy_coef == 0  # a zero written in the file overrides the preset's 0.01


def test_error_after_a_rewritten_name_keeps_its_original_place(tmp_path: Path) -> None:
    bad = tmp_path / "bad.pbtxt"
    line = "simulation { mode: OFFSCREEN offscreen { fps: 30 output: PNGG } }"
    bad.write_text(f"operation_mode: SIMULATION\n{line}\n")
    column = line.index("PNGG") + 1
    with pytest.raises(ConfigError, match=rf"{bad}:2:{column}: '{re.escape(line)}': .*PNGG"):
        load_file(bad, OPTIONS)
    bad.write_text("simulation {\n  replay { speed: 2 }\n  viewer { fps: fast }\n}\n")
    with pytest.raises(ConfigError, match=rf"{bad}:3:17: .*fast"):
        load_file(bad, OPTIONS)


@pytest.mark.parametrize(
    ("text", "where", "message"),
    [
        ("simulation { offscren { fps: 1 } }", "1:14", 'SimulationConfig has no field or option named "offscren". '
         "Did you mean: offscreen?"),
        ("simulation {\n  offscreen { fsp: 1 } }", "2:15", 'OffscreenOptions has no field or option named "fsp". '
         "Did you mean: fps?"),
        ("training { pp { } }", "1:12", 'TrainingConfig has no field or option named "pp". Did you mean: ppo?'),
    ],
)  # fmt: skip
def test_unknown_names_in_a_file_list_close_fields_and_options(tmp_path: Path, text: str, where: str, message: str):
    bad = tmp_path / "bad.pbtxt"
    bad.write_text(text)
    with pytest.raises(ConfigError, match=rf"{bad}:{where}: {re.escape(message)}"):
        load_file(bad, OPTIONS)


def test_an_option_of_a_missing_plugin_says_what_to_install(tmp_path: Path) -> None:
    bad = tmp_path / "bad.pbtxt"
    bad.write_text("simulation { offscreen { fps: 1 } }")
    hint = "'offscreen' is an option of joshua-modes, which is not installed or is disabled: pip install joshua-modes"
    with pytest.raises(ConfigError, match=rf":1:14: .*{re.escape(hint)}$"):
        load_file(bad, OptionSet())


def test_overrides_set_options_by_short_name() -> None:
    loaded = load_preset("sim_offscreen", OPTIONS)
    for assignment in (
        "simulation.offscreen.fps=60",
        "simulation.offscreen.output=MP4_AND_PNG",
        "simulation.offscreen.shadows=false",
        "simulation.replay.strict=true",
    ):
        apply_override(loaded.message, assignment, OPTIONS)
    offscreen = options_of(loaded.message.simulation, modes_options.offscreen)
    assert (offscreen.fps, offscreen.output) == (60, modes_options.OffscreenOptions.MP4_AND_PNG)
    assert offscreen.HasField("shadows") and not offscreen.shadows
    assert options_of(loaded.message.simulation, modes_options.replay).strict
    training = load_preset("ant_train_mjx_tuned", OPTIONS).message
    apply_override(training, "training.hidden_sizes=[16, 16]", OPTIONS)
    assert list(training.training.hidden_sizes) == [16, 16]


@pytest.mark.parametrize(
    ("assignment", "message"),
    [
        ("simulation.offscren.fps=3", "simulation has no field 'offscren'. Did you mean: offscreen?"),
        ("simulation.offscreen.fsp=3", "simulation.offscreen has no field 'fsp'. Did you mean: fps?"),
        ("simulation.offscreen.fps=fast", "Couldn't parse float: fast"),
        ("simulation.offscreen=3", "is a message"),
    ],
)
def test_bad_option_overrides_list_close_fields_and_options(assignment: str, message: str) -> None:
    with pytest.raises(UsageError, match=re.escape(message)) as caught:
        apply_override(load_preset("sim_offscreen", OPTIONS).message, assignment, OPTIONS)
    if "offscren" in assignment:
        assert "options: mirror, mirror_topic_mappings, offscreen, replay, viewer" in str(caught.value)


def test_lenient_reading_skips_names_it_does_not_know(tmp_path: Path) -> None:
    custom = tmp_path / "run.pbtxt"
    custom.write_text('description: "d"\nsimulation { mode: SAMPLE sample { level: 2 } offscreen { fps: 3 } }\n')
    loaded = load_file(custom, LENIENT)
    assert (loaded.message.description, loaded.message.simulation.mode) == ("d", "SAMPLE")
    apply_override(loaded.message, "simulation.sample.level=5", LENIENT)  # skipped, not an error
    apply_override(loaded.message, "simulation.keyframe=home", LENIENT)
    assert loaded.message.simulation.keyframe == "home"


def test_a_third_party_plugin_adds_options_without_touching_the_core(tmp_path: Path) -> None:
    host = PluginHost([(PluginInfo("sample", "joshua-sample", "1.0", "joshua_sample_plugin"), joshua_sample_plugin)])
    options = host.options()
    assert options.names(SimulationConfig.DESCRIPTOR) == ["sample"]
    custom = tmp_path / "run.pbtxt"
    custom.write_text("simulation {\n  mode: SAMPLE\n  sample { level: 2 sizes: [1, 2] }\n}\n")
    loaded = load_file(custom, options)
    apply_override(loaded.message, "simulation.sample.label=from --set", options)
    sample = options_of(loaded.message.simulation, joshua_sample_plugin.sample)
    assert (sample.level, list(sample.sizes), sample.label) == (2, [1, 2], "from --set")
    printed = config_text_of(loaded.message, options)
    assert "  sample {\n    level: 2\n" in printed and parse_text(printed, "printed", options) == loaded.message
    custom.write_text("simulation {\n  sample { levl: 2 }\n}\n")
    with pytest.raises(ConfigError, match=rf"{custom}:2:12: .*\"levl\". Did you mean: level, label\?"):
        load_file(custom, options)


def test_run_config_dicts_name_options_by_short_name() -> None:
    training = finalize(load_preset("ant_train_mjx_tuned", OPTIONS)).training
    document = message_to_dict(training)
    assert document["ppo"]["value_hidden_sizes"] == [256] * 5 and not any(key.startswith("[") for key in document)
    again = TrainingConfig()
    parse_dict(document, again, OPTIONS)
    assert again == training
    bracketed = TrainingConfig()
    parse_dict({"[joshua_ppo.ppo]": {"value_coef": 0.5}}, bracketed, OPTIONS)
    assert options_of(bracketed, ppo_options.ppo).value_coef == 0.5


# Finite numbers and bounds: one generic walk over the finalized config (joshua_core.limits).


@pytest.mark.parametrize(
    ("preset", "assignment", "expected"),
    [
        ("sim_offscreen", "simulation.duration=nan", "simulation.duration: must be finite, got nan"),
        ("sim_offscreen", "simulation.duration=-inf", "simulation.duration: must be finite, got -inf"),
        ("sim_offscreen", "simulation.offscreen.fps=nan", "simulation.offscreen.fps: must be finite, got nan"),
        ("sim_passive", "simulation.replay.speed=inf", "simulation.replay.speed: must be finite, got inf"),
        ("sim_passive", "simulation.replay.speed=-2", "simulation.replay.speed: must be at least 0, got -2"),
        ("sim_offscreen", "simulation.offscreen.fps=1e9", "simulation.offscreen.fps: must be at most 1000, got 1e+09"),
        ("sim_offscreen", "simulation.render_height=100000", "simulation.render_height: must be at most 8192"),
        ("sim_mirror", "simulation.mirror.display_fps=5000", "simulation.mirror.display_fps: must be at most 1000"),
        ("ant_train_mjx", "training.learning_rate=nan", "training.learning_rate: must be finite, got nan"),
        ("ant_train_mjx", "training.entropy_coef=inf", "training.entropy_coef: must be finite, got inf"),
    ],
)
def test_non_finite_and_absurd_numbers_are_config_errors(preset: str, assignment: str, expected: str) -> None:
    loaded = load_preset(preset, OPTIONS)
    apply_override(loaded.message, assignment, OPTIONS)
    with pytest.raises(ConfigError, match=re.escape(f"preset {preset}: {expected}")):
        finalize(loaded)


def test_non_finite_items_of_lists_are_named_by_index() -> None:
    loaded = load_preset("sim_mirror", OPTIONS)
    apply_override(loaded.message, "simulation.mirror_topic_mappings.mappings[1].offset=nan", OPTIONS)
    with pytest.raises(ConfigError, match=r"simulation.mirror_topic_mappings.mappings\[1\].offset: must be finite"):
        finalize(loaded)


def test_bounds_at_their_limit_are_accepted() -> None:
    loaded = load_preset("sim_offscreen", OPTIONS)
    for assignment in ("simulation.offscreen.fps=1000", "simulation.render_width=8192", "simulation.duration=0"):
        apply_override(loaded.message, assignment, OPTIONS)
    assert options_of(finalize(loaded).simulation, modes_options.offscreen).fps == 1000


def test_items_of_a_list_of_numbers_are_set_by_index() -> None:
    loaded = load_preset("ant_train_mjx_tuned", OPTIONS)
    apply_override(loaded.message, "training.hidden_sizes=[64, 64]", OPTIONS)
    apply_override(loaded.message, "training.hidden_sizes[1]=8", OPTIONS)
    apply_override(loaded.message, "training.hidden_sizes[2]=4", OPTIONS)  # one past the end appends
    assert list(loaded.message.training.hidden_sizes) == [64, 8, 4]
    with pytest.raises(UsageError, match=r"hidden_sizes has 3 items; use an index up to 3"):
        apply_override(loaded.message, "training.hidden_sizes[7]=8", OPTIONS)
    with pytest.raises(UsageError, match=r"Couldn't parse integer: x"):
        apply_override(loaded.message, "training.hidden_sizes[0]=x", OPTIONS)
    with pytest.raises(UsageError, match=r"'duration' is not a list or message: it cannot be indexed"):
        apply_override(loaded.message, "simulation.duration[0]=1", OPTIONS)


def test_a_binary_file_or_a_folder_as_config_is_a_usage_error(tmp_path: Path) -> None:
    binary = tmp_path / "model.pbtxt"
    binary.write_bytes(b"\x7fELF\x02\x01\x01\x00\xd0\xff\xfe")
    with pytest.raises(ConfigError, match=r"model.pbtxt: not a text config \(byte 8 is not UTF-8\)"):
        load_file(binary, OPTIONS)
    with pytest.raises(UsageError, match=r"is a directory; give a .pbtxt file in it"):
        load_file(tmp_path, OPTIONS)
