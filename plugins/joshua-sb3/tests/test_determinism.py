"""`training.deterministic` with the sb3 trainer: two runs of the same config and seed end with the same policy.

Bit-for-bit equality is a fair test only because both runs are the same program on the same machine, one after the
other; docs/determinism.md says what holds across machines and on a GPU."""

from __future__ import annotations

import os
import zipfile
from collections.abc import Iterator
from pathlib import Path

import pytest
import torch

from joshua_core.config import apply_override, finalize, load_preset
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.plugins import PluginHost
from joshua_core.run_context import RunContext
from joshua_sb3.run_folder import KEY_ENV_VAR, MODEL_FILE
from joshua_sb3.trainer import Sb3Trainer

pytestmark = pytest.mark.slow  # trains


@pytest.fixture
def torch_as_found() -> Iterator[None]:
    """Leave torch's deterministic-algorithms switch as the test found it (the trainer turns it on)."""
    before = torch.are_deterministic_algorithms_enabled()
    yield
    torch.use_deterministic_algorithms(before)


def policy_weights(checkpoint: Path) -> dict[str, torch.Tensor]:
    """The policy's tensors in a checkpoint's model.zip, as SB3 saved them."""
    with zipfile.ZipFile(checkpoint / MODEL_FILE) as archive, archive.open("policy.pth") as saved:
        return torch.load(saved, weights_only=True)


def train(host: PluginHost, root: Path) -> dict[str, torch.Tensor]:
    """A 256-step PPO run of the reaching preset with training.deterministic; its policy's tensors."""
    options = host.options()
    loaded = load_preset("so_arm100_reach_sb3", options)
    for assignment in (
        "training.deterministic=true",
        "training.num_envs=4",
        "training.num_steps=32",
        "training.minibatch_size=64",
        "training.num_epochs=2",
        "training.total_timesteps=256",
        "training.nthread=2",
        "training.run_name=same",
    ):
        apply_override(loaded.message, assignment, options)
    training: TrainingConfig = finalize(loaded).training
    return policy_weights(Sb3Trainer().train(training, RunContext(host, root)))


@pytest.mark.usefixtures("torch_as_found")
def test_two_deterministic_runs_end_with_the_same_policy(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(KEY_ENV_VAR, str(tmp_path / "checkpoint.key"))
    monkeypatch.setenv("XLA_FLAGS", os.environ.get("XLA_FLAGS", ""))  # restored afterwards, for later tests
    host = PluginHost.discover()
    first, second = train(host, tmp_path / "first"), train(host, tmp_path / "second")
    assert torch.are_deterministic_algorithms_enabled()
    assert first.keys() == second.keys()
    assert all(torch.equal(first[name], second[name]) for name in first)
