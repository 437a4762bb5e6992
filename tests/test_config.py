"""Config schema, presets, `extends`, `--set` overrides and path resolution."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

from joshua_core import config as config_module
from joshua_core.config import apply_override, finalize, load_file, load_preset, preset_names, simulation_mode
from joshua_core.config_pb2 import JoshuaConfig, SimulationConfig, TrainingConfig
from joshua_core.errors import ConfigError, ModelError, UsageError
from joshua_core.resources import models_dir

REPO_ROOT = Path(__file__).resolve().parents[1]

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
    assert len(generate.SCHEMAS) == 6  # the core's, four plugins' options, the joshua-rk4 example's
    for index, schema in enumerate(generate.SCHEMAS):
        for fresh in generate.generate(schema, tmp_path / str(index)):
            committed = schema.out_dir / fresh.name
            assert committed.read_bytes() == fresh.read_bytes(), f"{committed} is stale: run python proto/generate.py"


def test_simulation_config_keeps_the_seed_field_numbers() -> None:
    fields = {f.name: f.number for f in SimulationConfig.DESCRIPTOR.fields}
    assert {k: fields[k] for k in ("mode", "model_path", "trajectory_path", "mirror_topic_mappings")} == {
        "mode": 1,
        "model_path": 2,
        "trajectory_path": 3,
        "mirror_topic_mappings": 4,
    }
    assert (fields["render_width"], fields["render_height"]) == (5, 6)
    assert SimulationConfig.DESCRIPTOR.fields_by_name["mode"].type == SimulationConfig.DESCRIPTOR.fields_by_name[
        "model_path"
    ].type  # a string: plugins add modes by name


def test_the_seed_mode_names_parse_bare_or_quoted_and_empty_means_interactive(tmp_path: Path) -> None:
    for mode in ("INTERACTIVE", "PASSIVE", "MIRROR", "OFFSCREEN", "HEADLESS"):
        for written in (mode, f'"{mode}"'):
            (tmp_path / "run.pbtxt").write_text(f"operation_mode: SIMULATION\nsimulation {{ mode: {written} }}\n")
            assert load_file(tmp_path / "run.pbtxt").message.simulation.mode == mode
    assert simulation_mode(SimulationConfig()) == "INTERACTIVE"
    assert finalize(load_preset("so_arm100_sim_interactive")).simulation.mode == "INTERACTIVE"


PLUGIN_PRESETS = {
    "so_arm100_reach_sb3",
    "ant_train_mjx_tuned",
}  # presets added with the plugins, beyond the product's nine


def test_the_shipped_presets_each_parse_with_a_description() -> None:
    assert set(preset_names()) == SEED_PRESETS | {"sim_offscreen"} | PLUGIN_PRESETS
    for name in preset_names():
        loaded = load_preset(name)
        assert loaded.message.description, name
        assert "\n" not in loaded.message.description
        finalize(loaded)  # every model and trajectory a preset names exists


def test_preset_model_paths_resolve_against_shipped_models_from_any_cwd(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    config = finalize(load_preset("sim_passive"))
    assert Path(config.simulation.model_path) == (models_dir() / "so_arm100" / "scene.xml").resolve()
    assert Path(config.simulation.trajectory_path).is_file()


def test_mirror_preset_carries_the_seed_offsets() -> None:
    mappings = load_preset("sim_mirror").message.simulation.mirror_topic_mappings.mappings
    assert [(m.ros_topic, m.mujoco_actuator) for m in mappings] == [
        (f"/encoder/joint_{i}", f"joint_{i}_position") for i in range(1, 7)
    ]
    assert [round(m.offset, 6) for m in mappings] == [0.0, -0.087, 0.052, 0.0, -0.034, 0.0]


def test_parse_error_reports_file_line_and_column(tmp_path: Path) -> None:
    bad = tmp_path / "bad.pbtxt"
    bad.write_text('operation_mode: SIMULATION\nsimulation {\n  mode: PASSIVE\n  modl_path: "x.xml"\n}\n')
    with pytest.raises(ConfigError, match=rf"{bad}:4:3: .*modl_path"):
        load_file(bad)


def test_bad_enum_value_is_a_located_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.pbtxt"
    bad.write_text("operation_mode: SIDEWAYS\n")
    with pytest.raises(ConfigError, match=rf"{bad}:1:17: .*SIDEWAYS"):
        load_file(bad)


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
    message = load_file(custom).message
    assert message.simulation.mode == "MIRROR"  # from the preset
    assert message.simulation.model_path == "so_arm100/scene.xml"  # from the preset
    assert message.simulation.render_width == 320  # from the file
    assert [m.ros_topic for m in message.simulation.mirror_topic_mappings.mappings] == ["/arm/j1"]


def test_extends_of_an_unknown_preset_suggests_close_names(tmp_path: Path) -> None:
    custom = tmp_path / "lab.pbtxt"
    custom.write_text('extends: "sim_pasive"\n')
    with pytest.raises(UsageError, match="Did you mean: sim_passive"):
        load_file(custom)


def test_extends_cycle_is_reported(tmp_path: Path, monkeypatch) -> None:
    (tmp_path / "a.pbtxt").write_text('extends: "b"\n')
    (tmp_path / "b.pbtxt").write_text('extends: "a"\n')
    monkeypatch.setattr(config_module, "presets_dir", lambda: tmp_path)
    with pytest.raises(ConfigError, match="cycle: a -> b -> a"):
        load_preset("a")


def test_overrides_set_scalars_enums_strings_and_list_items() -> None:
    config = load_preset("sim_mirror").message
    apply_override(config, "simulation.render_width=1280")
    apply_override(config, "simulation.mode=OFFSCREEN")
    apply_override(config, "simulation.keyframe=home")
    apply_override(config, "simulation.mirror_topic_mappings.mappings[1].offset=0.25")
    apply_override(config, "simulation.mirror_topic_mappings.mappings[6].ros_topic=/encoder/extra")
    assert config.simulation.render_width == 1280
    assert config.simulation.mode == "OFFSCREEN"
    assert config.simulation.keyframe == "home"
    mappings = config.simulation.mirror_topic_mappings.mappings
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
        apply_override(load_preset("sim_mirror").message, assignment)


def test_training_defaults_follow_the_framework() -> None:
    mjx = finalize(load_preset("ant_train_mjx")).training
    assert (mjx.framework, mjx.trainer, mjx.backend) == (TrainingConfig.MJX, "ppo", "mjx")
    assert (mjx.num_envs, mjx.num_steps, mjx.num_epochs, mjx.minibatch_size) == (2048, 10, 4, 256)
    assert (mjx.learning_rate, mjx.gamma, mjx.clip_epsilon) == pytest.approx((3e-4, 0.99, 0.2))
    isaac = finalize(load_preset("isaac_trileg")).training
    assert (isaac.trainer, isaac.backend) == ("sb3", "usd")


def test_missing_model_names_every_path_searched(tmp_path: Path) -> None:
    custom = tmp_path / "run.pbtxt"
    custom.write_text('simulation { mode: HEADLESS model_path: "robots/nowhere.xml" }\n')
    with pytest.raises(ModelError) as caught:
        finalize(load_file(custom))
    text = str(caught.value)
    assert str(tmp_path / "robots" / "nowhere.xml") in text
    assert str(models_dir() / "robots" / "nowhere.xml") in text


def test_relative_model_path_in_a_custom_file_resolves_beside_it(tmp_path: Path) -> None:
    (tmp_path / "robot.xml").write_text("<mujoco/>")
    custom = tmp_path / "run.pbtxt"
    custom.write_text('simulation { mode: HEADLESS model_path: "robot.xml" }\n')
    assert finalize(load_file(custom)).simulation.model_path == str(tmp_path / "robot.xml")


def test_negative_sizes_are_rejected() -> None:
    loaded = load_preset("sim_offscreen")
    apply_override(loaded.message, "simulation.render_width=-5")
    with pytest.raises(ConfigError, match="must not be negative"):
        finalize(loaded)


def test_default_config_is_a_headless_run() -> None:
    config = finalize(config_module.load_default())
    assert config.operation_mode == JoshuaConfig.SIMULATION
    assert config.simulation.mode == "HEADLESS"


def test_extends_is_applied_and_cannot_be_set_from_the_command_line(tmp_path: Path) -> None:
    custom = tmp_path / "lab.pbtxt"
    custom.write_text('extends: "sim_passive"\n')
    assert load_file(custom).message.extends == ""
    with pytest.raises(UsageError, match="extends"):
        apply_override(load_preset("sim_passive").message, "extends=sim_mirror")


def test_negative_hyper_parameters_are_rejected() -> None:
    loaded = load_preset("ant_train_mjx")
    apply_override(loaded.message, "training.learning_rate=-0.1")
    with pytest.raises(ConfigError, match="learning_rate must not be negative"):
        finalize(loaded)
