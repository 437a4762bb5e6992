"""`training.deterministic` with the ppo trainer: XLA's deterministic-ops flag is in XLA_FLAGS, and two runs of the
same config and seed end with the same parameters.

Bit-for-bit equality is a fair test only because both runs are the same program on the same machine, one after the
other; docs/determinism.md says what holds across machines and on a GPU."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from distributed_worker import plugins

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.determinism import XLA_DETERMINISTIC_OPS, XLA_FLAGS_VAR
from joshua_core.options import parse_dict
from joshua_core.plugins import PluginHost
from joshua_core.run_context import RunContext
from joshua_ppo.checkpoints import PARAMS_FILE
from joshua_ppo.trainer import PpoTrainer

pytestmark = pytest.mark.slow  # trains

SLIDER = {  # 2 iterations of 8 environments x 8 steps on the smallest test model
    "task": "slider_reach",
    "deterministic": True,
    "num_envs": 8,
    "num_steps": 8,
    "num_epochs": 2,
    "minibatch_size": 32,
    "total_timesteps": 128,
    "seed": 3,
    "hidden_sizes": [16],
    "run_name": "same",
    "ppo": {"video_interval": -1},
}


def train(host: PluginHost, root: Path) -> bytes:
    """The saved parameters and normaliser (params.msgpack) of a SLIDER run in `root`."""
    config = TrainingConfig()
    parse_dict(SLIDER, config, host.options())
    return (PpoTrainer().train(config, RunContext(host, root)) / PARAMS_FILE).read_bytes()


def test_two_deterministic_runs_end_with_the_same_parameters(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(XLA_FLAGS_VAR, os.environ.get(XLA_FLAGS_VAR, ""))  # restored afterwards, for later tests
    host = plugins()
    first = train(host, tmp_path / "first")
    assert XLA_DETERMINISTIC_OPS in os.environ[XLA_FLAGS_VAR].split()
    assert train(host, tmp_path / "second") == first
