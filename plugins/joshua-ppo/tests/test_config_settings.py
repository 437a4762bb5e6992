"""A TrainingConfig becomes PPO's settings: every field left zero takes the settings dataclasses' default, the
fields set replace it."""

from __future__ import annotations

import pytest

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.options import options_of
from joshua_ppo import options_pb2
from joshua_ppo.config_settings import ppo_settings
from joshua_ppo.options_pb2 import PpoOptions
from joshua_ppo.settings import NetworkSettings, OptimizationSettings, ReturnSettings, RolloutSettings


def test_an_empty_config_takes_every_default_of_the_settings_dataclasses() -> None:
    settings = ppo_settings(PpoOptions(), TrainingConfig())
    assert settings.groups == {
        "rollout": RolloutSettings(),
        "optimization": OptimizationSettings(),
        "returns": ReturnSettings(),
        "network": NetworkSettings(),
    }


def test_the_fields_a_config_sets_replace_the_defaults() -> None:
    config = TrainingConfig(num_steps=5, num_epochs=2, minibatch_size=64, gamma=0.5, total_timesteps=1000)
    config.hidden_sizes.extend([32, 16])
    config.disable_normalization = True
    options = options_of(config, options_pb2.ppo)
    options.activation = "tanh"
    options.max_grad_norm = -1.0  # negative: no clipping
    options.anneal_learning_rate = True
    settings = ppo_settings(options_of(config, options_pb2.ppo), config)
    assert (settings.rollout.num_steps, settings.rollout.unrolls_per_iteration) == (5, 1)
    assert (settings.optimization.num_epochs, settings.optimization.minibatch_size) == (2, 64)
    assert settings.optimization.learning_rate == OptimizationSettings().learning_rate
    assert settings.optimization.max_grad_norm is None
    assert settings.optimization.anneal_steps == 1000
    assert settings.returns.gamma == 0.5  # exact in float32
    assert settings.network.hidden_sizes == (32, 16)
    assert settings.network.activation == "tanh"
    assert not settings.network.normalize_observations
    assert settings.checkpoint_interval == 100  # a tenth of total_timesteps


def test_an_unknown_activation_is_a_config_error() -> None:
    config = TrainingConfig()
    options_of(config, options_pb2.ppo).activation = "gelu"
    with pytest.raises(ConfigError, match="activation 'gelu' is not one of: relu"):
        ppo_settings(options_of(config, options_pb2.ppo), config)
