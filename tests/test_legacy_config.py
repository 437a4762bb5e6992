"""Old spellings of fields that left the core schema still load, with a one-line notice naming the new one."""

from __future__ import annotations

import pytest

from joshua_core.config import apply_override, config_text_of, finalize, load_file, load_preset, parse_text
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError, UsageError
from joshua_core.options import LENIENT, parse_dict
from joshua_core.plugins import PluginHost

OPTIONS = PluginHost.discover().options()


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
