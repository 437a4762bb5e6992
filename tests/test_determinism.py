"""`training.deterministic`: what `use_determinism` sets, and `--deterministic` as its shorthand."""

from __future__ import annotations

import os

import pytest

from joshua_core.cli import main
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.determinism import XLA_DETERMINISTIC_OPS, XLA_FLAGS_VAR, use_determinism


def test_the_flag_joins_the_users_xla_flags_once(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(XLA_FLAGS_VAR, "--xla_dump_to=/tmp/x")
    assert not use_determinism(TrainingConfig())
    assert os.environ[XLA_FLAGS_VAR] == "--xla_dump_to=/tmp/x"
    assert use_determinism(TrainingConfig(deterministic=True))
    assert use_determinism(TrainingConfig(deterministic=True))
    assert os.environ[XLA_FLAGS_VAR].split() == ["--xla_dump_to=/tmp/x", XLA_DETERMINISTIC_OPS]


def test_deterministic_sets_the_training_field(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--preset", "so_arm100_reach_sb3", "--deterministic", "--print-config"]) == 0
    assert "deterministic: true" in capsys.readouterr().out


def test_deterministic_is_refused_for_a_simulation(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--preset", "sim_offscreen", "--deterministic"]) == 2
    assert "--deterministic is for training configs" in capsys.readouterr().err
