"""The off-policy trainers' networks: an actor (deterministic for TD3, a Gaussian for SAC; from the flat
observation or, as a pixel actor, from camera images beside some of it) and a pair of critics Q(s, a).

The actor's dense layers are named Dense_0 .. Dense_k at its top level, as PPO's policy's are, so the exported
policy (`joshua_ppo.export.mlp_policy`) reads a state actor the same way: hidden layers, then the head, whose
first half is the mean where it also gives the log-std.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import linen as nn

from joshua_ppo.networks import ACTIVATIONS, ImageEncoder
from joshua_ppo.settings import PixelSettings

LOG_STD_BOUNDS = (-5.0, 2.0)  # of SAC's Gaussian before squashing: wide enough to explore, narrow enough to stay finite


class Actor(nn.Module):
    """Observation (and, for a pixel actor, its views) -> the action before tanh: the mean, and for a Gaussian
    actor the log-std beside it (last axis 2 x action_dim)."""

    action_dim: int
    hidden_sizes: tuple[int, ...]
    activation: str = "relu"
    gaussian: bool = False
    pixels: PixelSettings | None = None
    observation_indices: tuple[int, ...] = ()

    @nn.compact
    def __call__(self, x: jax.Array, views: dict[str, dict[str, jax.Array]] | None = None) -> jax.Array:
        if self.pixels is not None:
            assert views is not None, "a pixel actor sees its views"
            images = [ImageEncoder(self.pixels, name=f"encoder_{name}")(views["images"][name])
                      for name in self.pixels.cameras]  # fmt: skip
            flat = jnp.take(x, jnp.asarray(self.observation_indices, jnp.int32), axis=-1)
            commands = [views["commands"][name].astype(x.dtype) for name in self.pixels.commands]
            x = jnp.concatenate([*images, flat, *commands], axis=-1)
        for size in self.hidden_sizes:
            x = ACTIVATIONS[self.activation](nn.Dense(size)(x))
        return nn.Dense(2 * self.action_dim if self.gaussian else self.action_dim)(x)


class _Critic(nn.Module):
    hidden_sizes: tuple[int, ...]
    activation: str

    @nn.compact
    def __call__(self, x: jax.Array, action: jax.Array) -> jax.Array:
        x = jnp.concatenate([x, action], axis=-1)
        for size in self.hidden_sizes:
            x = ACTIVATIONS[self.activation](nn.Dense(size)(x))
        return nn.Dense(1)(x)[..., 0]


class Critics(nn.Module):
    """Two independent Q networks of one shape, evaluated together: (observation, action) -> Q (2, batch); the
    smaller of the two is the clipped double-Q estimate (Fujimoto et al. 2018)."""

    hidden_sizes: tuple[int, ...]
    activation: str = "relu"

    @nn.compact
    def __call__(self, x: jax.Array, action: jax.Array) -> jax.Array:
        pair = nn.vmap(
            _Critic,
            variable_axes={"params": 0},
            split_rngs={"params": True},
            in_axes=None,
            out_axes=0,
            axis_size=2,
        )
        return pair(self.hidden_sizes, self.activation, name="pair")(x, action)


def squashed_gaussian(head: jax.Array, noise: jax.Array) -> tuple[jax.Array, jax.Array]:
    """A SAC actor's head (mean, log-std) and standard normal `noise` -> the squashed action tanh(mean + std noise)
    and its log-density (the Gaussian's, corrected for the tanh), summed over the action's dimensions."""
    mean, raw = jnp.split(head, 2, axis=-1)
    low, high = LOG_STD_BOUNDS
    log_std = low + 0.5 * (high - low) * (jnp.tanh(raw) + 1.0)
    u = mean + jnp.exp(log_std) * noise
    gaussian = -0.5 * jnp.square(noise) - log_std - 0.5 * jnp.log(2.0 * jnp.pi)
    log_det = 2.0 * (jnp.log(2.0) - u - nn.softplus(-2.0 * u))  # log(1 - tanh(u)^2), stably
    return jnp.tanh(u), jnp.sum(gaussian - log_det, axis=-1)


def deterministic_action(head: jax.Array, gaussian: bool) -> jax.Array:
    """The action an actor's head means: tanh of its mean (the first half of a Gaussian's head)."""
    mean = jnp.split(head, 2, axis=-1)[0] if gaussian else head
    return jnp.tanh(mean)
