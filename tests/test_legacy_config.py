"""Old spellings of fields that left the core schema, or moved into it from a plugin's options, still load, with a
one-line notice naming the new one."""

from __future__ import annotations

import json

import pytest
from google.protobuf import json_format

from joshua_core import hookimpl
from joshua_core.config import apply_override, config_text_of, finalize, load_file, load_preset, parse_text
from joshua_core.config_pb2 import JoshuaConfig, TrainingConfig
from joshua_core.errors import ConfigError, UsageError
from joshua_core.options import LENIENT, parse_dict
from joshua_core.plugins import PluginHost, PluginInfo, Registrar
from joshua_core.runs import saved_training

OPTIONS = PluginHost.discover().options()
PPO = OPTIONS.find(TrainingConfig.DESCRIPTOR, "ppo")
SB3 = OPTIONS.find(TrainingConfig.DESCRIPTOR, "sb3")


def training_of(text: str, options=OPTIONS) -> TrainingConfig:
    return parse_text(f"operation_mode: TRAINING\ntraining {{\n{text}\n}}\n", "old.pbtxt", options).training


def test_an_old_framework_loads_as_its_trainer_and_backend_with_a_notice(capsys) -> None:
    training = training_of('  framework: SB3\n  task: "so_arm100_reach"')
    assert (training.trainer, training.backend, training.task) == ("sb3", "mujoco", "so_arm100_reach")
    notice = capsys.readouterr().err
    assert notice == (
        'joshua: notice: old.pbtxt:3:3: training.framework is gone; framework: SB3 is now trainer: "sb3" '
        'backend: "mujoco"\n'
    )


def test_the_fields_a_config_sets_itself_win_over_its_old_framework(capsys) -> None:
    assert (training_of('  trainer: "td3" framework: MJX').trainer, training_of("  framework: MJX").backend) == (
        "td3",
        "mjx",
    )
    isaac = training_of('  framework: SB3\n  backend: "usd"')
    assert (isaac.trainer, isaac.backend) == ("sb3", "usd")
    assert training_of("  framework: 1").trainer == "sb3"  # the enum's number


def test_a_lenient_read_rewrites_without_the_notice(capsys) -> None:
    assert training_of("  framework: SB3 num_envs: 4", LENIENT).trainer == "sb3"
    assert capsys.readouterr().err == ""


def test_errors_after_an_old_field_point_at_the_original_text() -> None:
    with pytest.raises(ConfigError, match=r"old.pbtxt:3:18: .*\"num_env\""):
        training_of("  framework: SB3 num_env: 4")
    with pytest.raises(ConfigError, match=r"old.pbtxt:3:3: training.framework 'PYTORCH' is not one of MJX, SB3"):
        training_of("  framework: PYTORCH")


def test_an_old_framework_by_set_and_in_a_run_folder_dict(capsys) -> None:
    loaded = load_preset("ant_train_mjx", OPTIONS)
    apply_override(loaded.message, "training.framework=SB3", OPTIONS)
    assert (loaded.message.training.trainer, loaded.message.training.backend) == ("sb3", "mujoco")
    assert 'training.framework=SB3: training.framework is gone; framework: SB3 is now trainer: "sb3"' in (
        capsys.readouterr().err
    )
    with pytest.raises(UsageError, match="'GPU' is not one of MJX, SB3"):
        apply_override(loaded.message, "training.framework=GPU", OPTIONS)
    saved = TrainingConfig()
    parse_dict({"framework": "SB3", "backend": "usd", "num_envs": 8}, saved, OPTIONS)  # an old config.json
    assert (saved.trainer, saved.backend, saved.num_envs) == ("sb3", "usd", 8)


def test_an_old_config_file_prints_in_the_new_spelling(tmp_path, capsys) -> None:
    old = tmp_path / "old.pbtxt"
    old.write_text('extends: "so_arm100_reach_sb3"\ntraining { framework: MJX }\n')
    config = finalize(load_file(old, OPTIONS))
    assert (config.training.trainer, config.training.backend) == ("ppo", "mjx")
    printed = config_text_of(config, OPTIONS)
    assert "framework" not in printed and 'trainer: "ppo"' in printed
    assert capsys.readouterr().err.count("framework: MJX is now") == 1  # once, though merged over its preset


def test_trainer_options_that_moved_load_as_the_training_fields_with_a_notice(capsys) -> None:
    training = training_of(
        '  ppo { run_name: "x" hidden_sizes: [64,\n 32] value_coef: 0.5 entropy_coef: 0.25 }\n'
        "  offpolicy { checkpoint_interval: 500 disable_observation_normalization: true }\n"
        '  sb3 { resume: true algorithm: "SAC" }'
    )
    assert (training.run_name, list(training.hidden_sizes), training.entropy_coef) == ("x", [64, 32], 0.25)
    assert (training.checkpoint_interval, training.disable_normalization, training.resume) == (500, True, True)
    assert training.Extensions[PPO].value_coef == 0.5 and training.Extensions[SB3].algorithm == "SAC"
    notices = capsys.readouterr().err.splitlines()
    assert notices[0] == "joshua: notice: old.pbtxt:3:9: training.ppo.run_name is now training.run_name"
    assert notices[4] == (
        "joshua: notice: old.pbtxt:5:40: training.offpolicy.disable_observation_normalization is now "
        "training.disable_normalization"
    )
    assert len(notices) == 6 and all(line.startswith("joshua: notice: old.pbtxt:") for line in notices)


def test_an_option_that_held_only_moved_fields_is_left_unset(capsys) -> None:
    training = training_of("  sb3 { disable_normalization: true hidden_sizes: 8 hidden_sizes: 8 }")
    assert training.disable_normalization and list(training.hidden_sizes) == [8, 8]
    assert not training.HasExtension(SB3) and "sb3 {" not in config_text_of_training(training)


def test_both_spellings_set_differently_is_a_one_line_error(capsys) -> None:
    with pytest.raises(ConfigError, match=r"^old.pbtxt:4:9: training.ppo.run_name and training.run_name are both set"):
        training_of('  run_name: "a"\n  ppo { run_name: "b" }')
    with pytest.raises(ConfigError, match=r"training.sb3.hidden_sizes and training.hidden_sizes are both set"):
        training_of("  ppo { hidden_sizes: [8] }\n  sb3 { hidden_sizes: [16] }")
    same = training_of('  run_name: "a"\n  ppo { run_name: "a" }\n  sb3 { run_name: "a" }')  # no conflict
    assert same.run_name == "a"


def test_an_old_spelling_over_a_preset_overrides_it_and_notices_once(tmp_path, capsys) -> None:
    old = tmp_path / "old.pbtxt"
    old.write_text('extends: "ant_train_mjx_tuned"\ntraining { ppo { hidden_sizes: [32] entropy_coef: 0 } }\n')
    training = load_file(old, OPTIONS).message.training
    assert list(training.hidden_sizes) == [32] and training.entropy_coef == 0  # the preset's: 4 x 128, 0.01
    assert training.Extensions[PPO].squash_actions  # the rest of the preset's ppo options stay
    assert capsys.readouterr().err.count("training.ppo.hidden_sizes is now training.hidden_sizes") == 1


def test_moved_options_by_set(capsys) -> None:
    loaded = load_preset("so_arm100_reach_sb3", OPTIONS)
    apply_override(loaded.message, "training.ppo.resume=true", OPTIONS)
    apply_override(loaded.message, "training.sb3.hidden_sizes[1]=8", OPTIONS)
    apply_override(loaded.message, "training.sb3.run_name=r", LENIENT)  # the CLI's first pass: left to the second
    training = loaded.message.training
    assert training.resume and list(training.hidden_sizes) == [64, 8] and not training.run_name
    assert capsys.readouterr().err.splitlines() == [
        "joshua: notice: --set training.ppo.resume=true: training.ppo.resume is now training.resume",
        "joshua: notice: --set training.sb3.hidden_sizes[1]=8: training.sb3.hidden_sizes is now training.hidden_sizes",
    ]


def test_moved_options_in_an_old_run_folders_config_json(tmp_path, capsys) -> None:
    saved = TrainingConfig()
    parse_dict({"ppo": {"run_name": "old", "video_interval": -1}, "num_envs": 8}, saved, OPTIONS, "run/config.json")
    assert (saved.run_name, saved.num_envs, saved.Extensions[PPO].video_interval) == ("old", 8, -1)
    assert (
        capsys.readouterr().err == "joshua: notice: run/config.json: training.ppo.run_name is now training.run_name\n"
    )
    with pytest.raises(json_format.ParseError, match="training.offpolicy.resume and training.resume are both set"):
        parse_dict({"resume": False, "offpolicy": {"resume": True}}, TrainingConfig(), OPTIONS)
    checkpoint = tmp_path / "run_step_8"
    checkpoint.mkdir()
    document = {"trainer": "ppo", "format": "f", "training": {"run_name": "a", "ppo": {"run_name": "b"}}}
    (checkpoint / "config.json").write_text(json.dumps(document))
    with pytest.raises(UsageError, match="config.json: unreadable training config: training.ppo.run_name and"):
        saved_training(checkpoint, "f", OPTIONS)


def test_the_cli_refuses_both_spellings_in_one_line(run_joshua, tmp_path) -> None:
    config = tmp_path / "both.pbtxt"
    config.write_text('extends: "so_arm100_reach_sb3"\ntraining { run_name: "a" sb3 { run_name: "b" } }\n')
    result = run_joshua("--config", str(config), "--print-config")
    assert result.returncode == 2 and result.stderr.splitlines()[-1].startswith(f"joshua: error: {config}:2:32: ")
    assert result.stderr.count("\n") == 2, result.stderr  # the notice, then the error


def test_a_plugin_can_only_declare_a_field_moved_that_left_its_options() -> None:
    def host(moved: dict[str, str]) -> PluginHost:
        class Plugin:
            @staticmethod
            @hookimpl
            def joshua_register_options(registry: Registrar) -> None:
                registry.add("sb3", "joshua_sb3.options_pb2:sb3", moved=moved)

        built = PluginHost([(PluginInfo("moving", "moving", "0", "test"), Plugin())])
        built.options()
        return built

    assert host({"run_name": "run_name"}).options().moved_field(SB3, "run_name") == "run_name"
    for moved, problem in (({"algorithm": "algorithm"}, "still has it"), ({"resume": "restart"}, "does not exist")):
        broken = host(moved)
        assert broken.options().extensions == () and problem in broken.plugins[0].error


def config_text_of_training(training: TrainingConfig) -> str:
    config = JoshuaConfig(operation_mode=JoshuaConfig.TRAINING)
    config.training.CopyFrom(training)
    return config_text_of(config, OPTIONS)
