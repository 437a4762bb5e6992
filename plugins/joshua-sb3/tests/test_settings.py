"""A TrainingConfig becomes the SB3 trainer's settings: a zero count or rate means the trainer's default
(docs/configuration.md), never zero epochs or steps that would train nothing."""

from __future__ import annotations

import pytest

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.options import options_of
from joshua_sb3 import options_pb2
from joshua_sb3.options_pb2 import Sb3Options
from joshua_sb3.settings import sb3_settings


@pytest.mark.parametrize(
    ("algorithm", "num_steps", "num_epochs"),
    [("PPO", 64, 10), ("SAC", 1, 1)],  # SAC: one environment step, then one gradient step
)
def test_zero_counts_and_rates_take_the_trainers_defaults(algorithm: str, num_steps: int, num_epochs: int) -> None:
    config = TrainingConfig(num_steps=0, num_epochs=0, minibatch_size=0, learning_rate=0, gamma=0)
    options_of(config, options_pb2.sb3).algorithm = algorithm
    settings = sb3_settings(options_of(config, options_pb2.sb3), config)
    assert (settings.num_steps, settings.num_epochs, settings.minibatch_size) == (num_steps, num_epochs, 256)
    assert (settings.learning_rate, settings.gamma) == (3e-4, 0.99)  # the defaults themselves, exactly


def test_the_counts_a_config_sets_are_kept() -> None:
    settings = sb3_settings(Sb3Options(), TrainingConfig(num_steps=5, num_epochs=2, total_timesteps=1000))
    assert (settings.num_steps, settings.num_epochs, settings.total_timesteps) == (5, 2, 1000)
