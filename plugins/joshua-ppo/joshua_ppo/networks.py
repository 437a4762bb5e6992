"""The policy networks: the seed's ActorCritic (shared trunk, the default), separate policy and value
networks (Brax's layout), and the Gaussian policy's log-probability and entropy.

Both networks map observations to (mean (N, A), log_std (A,), value (N,)): a diagonal Gaussian
with a learned state-independent log-std, and a state-value estimate.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
from flax import linen as nn

_LOG_2PI = math.log(2.0 * math.pi)


def _mlp(x: jax.Array, hidden_sizes: tuple[int, ...]) -> jax.Array:
    for size in hidden_sizes:
        x = nn.relu(nn.Dense(size)(x))
    return x


class ActorCritic(nn.Module):
    """The seed's network: one ReLU trunk (default 256-256) under the policy mean and the value head."""

    action_dim: int
    hidden_sizes: tuple[int, ...] = (256, 256)

    @nn.compact
    def __call__(self, x: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
        x = _mlp(x, self.hidden_sizes)
        mean = nn.Dense(self.action_dim)(x)
        log_std = self.param("log_std", nn.initializers.zeros, (self.action_dim,))
        value = nn.Dense(1)(x)
        return mean, log_std, value[..., 0]


class SeparateActorCritic(nn.Module):
    """Policy and value as two ReLU networks: the value loss (large with reward scaling) cannot swamp
    the policy's features, and each network gets its own size (Brax's Ant: policy 4x32, value 5x256)."""

    action_dim: int
    policy_hidden_sizes: tuple[int, ...]
    value_hidden_sizes: tuple[int, ...]

    @nn.compact
    def __call__(self, x: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
        mean = nn.Dense(self.action_dim)(_mlp(x, self.policy_hidden_sizes))
        log_std = self.param("log_std", nn.initializers.zeros, (self.action_dim,))
        value = nn.Dense(1)(_mlp(x, self.value_hidden_sizes))
        return mean, log_std, value[..., 0]


def gaussian_log_prob(action: jax.Array, mean: jax.Array, log_std: jax.Array) -> jax.Array:
    """Log-density of `action` under the diagonal Gaussian, summed over action dimensions."""
    z = (action - mean) * jnp.exp(-log_std)
    return jnp.sum(-0.5 * jnp.square(z) - log_std - 0.5 * _LOG_2PI, axis=-1)


def gaussian_entropy(log_std: jax.Array) -> jax.Array:
    """Entropy of the diagonal Gaussian (it does not depend on the mean)."""
    return jnp.sum(log_std + 0.5 * (1.0 + _LOG_2PI), axis=-1)
