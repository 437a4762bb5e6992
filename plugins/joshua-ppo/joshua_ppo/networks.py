"""The policy networks: ActorCritic (shared trunk, the default), separate policy and value
networks (Brax's layout), a pixel policy (CNN encoders of camera images) beside a flat-state value
network, and the Gaussian policy's log-probability and entropy.

Both networks map observations to (mean (N, A), log_std, value (N,)): a diagonal Gaussian and a
state-value estimate. The log-std is one learned vector (A,) by default, or, with
`state_dependent_std`, an output of the policy network (N, A) (softplus of it plus 0.001 is the std).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import jax
import jax.numpy as jnp
from flax import linen as nn

from joshua_ppo.settings import PixelSettings

_LOG_2PI = math.log(2.0 * math.pi)
_MIN_STD = 1e-3  # floor of a state-dependent std, so that log-probabilities stay finite
ACTIVATIONS: dict[str, Callable[[jax.Array], jax.Array]] = {
    "relu": nn.relu,
    "swish": nn.swish,
    "tanh": nn.tanh,
    "elu": nn.elu,
}


def _mlp(x: jax.Array, hidden_sizes: tuple[int, ...], activation: str) -> jax.Array:
    for size in hidden_sizes:
        x = ACTIVATIONS[activation](nn.Dense(size)(x))
    return x


def _gaussian_head(
    module: nn.Module, x: jax.Array, action_dim: int, state_dependent_std: bool
) -> tuple[jax.Array, ...]:
    """Mean and log-std of the policy from its last hidden layer."""
    if state_dependent_std:
        mean, raw_std = jnp.split(nn.Dense(2 * action_dim)(x), 2, axis=-1)
        return mean, jnp.log(nn.softplus(raw_std) + _MIN_STD)
    return nn.Dense(action_dim)(x), module.param("log_std", nn.initializers.zeros, (action_dim,))


class ActorCritic(nn.Module):
    """The default network: one trunk (default ReLU 256-256) under the policy head and the value head."""

    action_dim: int
    hidden_sizes: tuple[int, ...] = (256, 256)
    activation: str = "relu"
    state_dependent_std: bool = False

    @nn.compact
    def __call__(self, x: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
        x = _mlp(x, self.hidden_sizes, self.activation)
        mean, log_std = _gaussian_head(self, x, self.action_dim, self.state_dependent_std)
        value = nn.Dense(1)(x)
        return mean, log_std, value[..., 0]


class SeparateActorCritic(nn.Module):
    """Policy and value as two networks: the value loss (large with reward scaling) cannot swamp
    the policy's features, and each network gets its own size (Brax's Ant: policy 4x32, value 5x256)."""

    action_dim: int
    policy_hidden_sizes: tuple[int, ...]
    value_hidden_sizes: tuple[int, ...]
    activation: str = "relu"
    state_dependent_std: bool = False

    @nn.compact
    def __call__(self, x: jax.Array, value_x: jax.Array | None = None) -> tuple[jax.Array, jax.Array, jax.Array]:
        """`value_x`: what the value network sees instead of `x` (the observation without its noise)."""
        policy = _mlp(x, self.policy_hidden_sizes, self.activation)
        mean, log_std = _gaussian_head(self, policy, self.action_dim, self.state_dependent_std)
        value = nn.Dense(1)(_mlp(x if value_x is None else value_x, self.value_hidden_sizes, self.activation))
        return mean, log_std, value[..., 0]


class ImageEncoder(nn.Module):
    """One camera's images (..., H, W, C) -> features (..., feature_size): conv layers (ReLU, SAME padding, so any
    image size works) and a dense layer. rgb (uint8) is scaled to [0, 1] here, so the rollout buffer keeps bytes;
    depth is read as is (metres)."""

    pixels: PixelSettings

    @nn.compact
    def __call__(self, images: jax.Array) -> jax.Array:
        leading = images.shape[:-3]
        x = images.reshape(-1, *images.shape[-3:])
        x = x.astype(jnp.float32) / 255.0 if images.dtype == jnp.uint8 else x.astype(jnp.float32)
        for channels, kernel, stride in zip(
            self.pixels.channels, self.pixels.kernel_sizes, self.pixels.strides, strict=True
        ):
            x = nn.relu(nn.Conv(channels, (kernel, kernel), (stride, stride), padding="SAME")(x))
        x = nn.relu(nn.Dense(self.pixels.feature_size)(x.reshape(x.shape[0], -1)))
        return x.reshape(*leading, -1)


class _Mlp(nn.Module):
    """Hidden layers as a named submodule, so its parameters keep their names whichever branches run."""

    hidden_sizes: tuple[int, ...]
    activation: str

    @nn.compact
    def __call__(self, x: jax.Array) -> jax.Array:
        return _mlp(x, self.hidden_sizes, self.activation)


class _GaussianHead(nn.Module):
    """The policy's mean and log-std (see _gaussian_head) as a named submodule."""

    action_dim: int
    state_dependent_std: bool

    @nn.compact
    def __call__(self, x: jax.Array) -> tuple[jax.Array, ...]:
        return _gaussian_head(self, x, self.action_dim, self.state_dependent_std)


class PixelActorCritic(nn.Module):
    """A policy that sees camera images (one ImageEncoder per camera), the flat observation's entries at
    `observation_indices` and the task's commands it names, beside a value network of the whole flat observation
    (privileged: the cube's pose the policy must find in the images). Without views only the value is computed
    (mean and log-std are None): the value of a final or last observation needs no images."""

    action_dim: int
    policy_hidden_sizes: tuple[int, ...]
    value_hidden_sizes: tuple[int, ...]
    pixels: PixelSettings
    observation_indices: tuple[int, ...]
    activation: str = "relu"
    state_dependent_std: bool = False

    @nn.compact
    def __call__(
        self, x: jax.Array, value_x: jax.Array | None = None, views: dict[str, dict[str, jax.Array]] | None = None
    ) -> tuple[jax.Array | None, jax.Array | None, jax.Array]:
        """`x`: the normalised flat observation; `value_x`: what the value network sees instead (the observation
        without its noise); `views`: {"images": each camera's by name, "commands": each command by name}."""
        value_hidden = _Mlp(self.value_hidden_sizes, self.activation, name="value")(x if value_x is None else value_x)
        value = nn.Dense(1, name="value_out")(value_hidden)[..., 0]
        if views is None:
            return None, None, value
        images, commands = views["images"], views["commands"]
        features = [ImageEncoder(self.pixels, name=f"encoder_{name}")(images[name]) for name in self.pixels.cameras]
        flat = jnp.take(x, jnp.asarray(self.observation_indices, jnp.int32), axis=-1)
        given = [commands[name].astype(x.dtype) for name in self.pixels.commands]
        policy_input = jnp.concatenate([*features, flat, *given], axis=-1)
        policy = _Mlp(self.policy_hidden_sizes, self.activation, name="policy")(policy_input)
        mean, log_std = _GaussianHead(self.action_dim, self.state_dependent_std, name="policy_head")(policy)
        return mean, log_std, value


def gaussian_log_prob(action: jax.Array, mean: jax.Array, log_std: jax.Array) -> jax.Array:
    """Log-density of `action` under the diagonal Gaussian, summed over action dimensions."""
    z = (action - mean) * jnp.exp(-log_std)
    return jnp.sum(-0.5 * jnp.square(z) - log_std - 0.5 * _LOG_2PI, axis=-1)


def gaussian_entropy(log_std: jax.Array) -> jax.Array:
    """Entropy of the diagonal Gaussian (it does not depend on the mean)."""
    return jnp.sum(log_std + 0.5 * (1.0 + _LOG_2PI), axis=-1)


def squashed_entropy(mean: jax.Array, log_std: jax.Array, noise: jax.Array) -> jax.Array:
    """One-sample estimate of the entropy of tanh(Gaussian), the actions a squashing policy sends.

    The Gaussian's entropy plus E[log |d tanh(u)/du|] at u = mean + std * noise: unlike the Gaussian's
    own entropy it does not keep growing with the std, as ever wider samples only saturate at +-1.
    """
    u = mean + jnp.exp(log_std) * noise
    log_det_jacobian = 2.0 * (math.log(2.0) - u - nn.softplus(-2.0 * u))  # log(1 - tanh(u)^2), stably
    return gaussian_entropy(log_std) + jnp.sum(log_det_jacobian, axis=-1)
