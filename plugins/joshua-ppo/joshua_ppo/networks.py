"""The default policy network: the seed's ActorCritic, and the Gaussian policy's log-probability and entropy."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
from flax import linen as nn

_LOG_2PI = math.log(2.0 * math.pi)


class ActorCritic(nn.Module):
    """Shared ReLU trunk (default 256-256), Gaussian policy mean with a learned state-independent log-std,
    and a value head. Returns (mean (N, A), log_std (A,), value (N,))."""

    action_dim: int
    hidden_sizes: tuple[int, ...] = (256, 256)

    @nn.compact
    def __call__(self, x: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
        for size in self.hidden_sizes:
            x = nn.relu(nn.Dense(size)(x))
        mean = nn.Dense(self.action_dim)(x)
        log_std = self.param("log_std", nn.initializers.zeros, (self.action_dim,))
        value = nn.Dense(1)(x)
        return mean, log_std, value[..., 0]


def gaussian_log_prob(action: jax.Array, mean: jax.Array, log_std: jax.Array) -> jax.Array:
    """Log-density of `action` under the diagonal Gaussian, summed over action dimensions."""
    z = (action - mean) * jnp.exp(-log_std)
    return jnp.sum(-0.5 * jnp.square(z) - log_std - 0.5 * _LOG_2PI, axis=-1)


def gaussian_entropy(log_std: jax.Array) -> jax.Array:
    """Entropy of the diagonal Gaussian (it does not depend on the mean)."""
    return jnp.sum(log_std + 0.5 * (1.0 + _LOG_2PI), axis=-1)
