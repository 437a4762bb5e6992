"""A TrainingConfig's PPO hyper-parameters turned into `train_ppo`'s settings, with the defaults filled in."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.options import options_of
from joshua_ppo import options_pb2
from joshua_ppo.networks import ACTIVATIONS
from joshua_ppo.options_pb2 import PpoOptions
from joshua_ppo.settings import NetworkSettings, OptimizationSettings, ReturnSettings, RolloutSettings

DEFAULT_TOTAL_TIMESTEPS = 50_000_000
CHECKPOINTS_PER_RUN = 10


@dataclass(frozen=True)
class PpoSettings:
    """A TrainingConfig's PPO hyper-parameters with the defaults filled in (docs/training-mjx.md#ppo-options)."""

    rollout: RolloutSettings
    optimization: OptimizationSettings
    returns: ReturnSettings
    network: NetworkSettings
    total_timesteps: int
    checkpoint_interval: int
    seed: int

    @property
    def groups(self) -> dict[str, Any]:
        """The four settings groups as the keyword arguments `train_ppo` and `make_iteration` take."""
        return {
            "rollout": self.rollout,
            "optimization": self.optimization,
            "returns": self.returns,
            "network": self.network,
        }

    @classmethod
    def from_config(cls, config: TrainingConfig) -> PpoSettings:
        options = options_of(config, options_pb2.ppo)
        for name in ("hidden_sizes", "value_hidden_sizes"):
            if any(size <= 0 for size in getattr(options, name)):
                raise ConfigError(f"training.ppo.{name} must be positive, got {list(getattr(options, name))}")
        activation = options.activation or "relu"
        if activation not in ACTIVATIONS:
            raise ConfigError(f"training.ppo.activation '{options.activation}' is not one of: {', '.join(ACTIVATIONS)}")
        if options.desired_kl < 0:
            raise ConfigError(f"training.ppo.desired_kl must not be negative, got {options.desired_kl}")
        for name in ("num_steps", "num_epochs", "minibatch_size", "total_timesteps"):  # num_envs: by EnvSpec
            if getattr(config, name) < 0:
                raise ConfigError(f"training.{name} must not be negative")
        total = config.total_timesteps or DEFAULT_TOTAL_TIMESTEPS
        max_grad_norm = options.max_grad_norm or 1.0
        return cls(
            rollout=RolloutSettings(
                num_steps=config.num_steps or 10,
                unrolls_per_iteration=options.unrolls_per_iteration or 1,
            ),
            optimization=OptimizationSettings(
                num_epochs=config.num_epochs or 4,
                minibatch_size=config.minibatch_size or 256,
                learning_rate=config.learning_rate or 3e-4,
                clip_epsilon=config.clip_epsilon or 0.2,
                entropy_coef=options.entropy_coef,
                value_coef=options.value_coef or 0.5,
                max_grad_norm=None if max_grad_norm < 0 else max_grad_norm,
                desired_kl=options.desired_kl,
                anneal_steps=total if options.anneal_learning_rate else 0,
            ),
            returns=ReturnSettings(
                gamma=config.gamma or 0.99,
                gae_lambda=config.gae_lambda or 0.95,
                reward_scaling=options.reward_scaling or 1.0,
                recompute_advantages=options.recompute_advantages,
                advantage=PpoOptions.Advantage.Name(options.advantage).lower(),
            ),
            network=NetworkSettings(
                hidden_sizes=tuple(options.hidden_sizes) or (256, 256),
                value_hidden_sizes=tuple(options.value_hidden_sizes),
                normalize_observations=not options.disable_observation_normalization,
                squash_actions=options.squash_actions,
                activation=activation,
                state_dependent_std=options.state_dependent_std,
            ),
            total_timesteps=total,
            checkpoint_interval=options.checkpoint_interval or max(1, total // CHECKPOINTS_PER_RUN),
            seed=int(config.seed),
        )
