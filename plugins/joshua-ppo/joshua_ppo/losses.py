"""The PPO loss (clipped surrogate, value regression, entropy bonus), a teacher's imitation term and the policy's
entropy, as plain functions.

They take the network's outputs on a minibatch and what was saved when it was collected; applying the
network and estimating the advantages is the compiled iteration's job (`joshua_ppo.iteration`).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from joshua_ppo.networks import gaussian_entropy, gaussian_log_prob, squashed_entropy
from joshua_ppo.settings import OptimizationSettings


def policy_entropy(mean: jax.Array, log_std: jax.Array, key: jax.Array, squash_actions: bool) -> jax.Array:
    """Mean entropy of the action distribution (of the squashed actions when the policy squashes)."""
    if squash_actions:
        return squashed_entropy(mean, log_std, jax.random.normal(key, mean.shape)).mean()
    return gaussian_entropy(log_std).mean()  # log_std (A,) or (N, A): the mean is the same


def ppo_loss(
    mean: jax.Array,
    log_std: jax.Array,
    value: jax.Array,
    *,
    action: jax.Array,
    old_log_prob: jax.Array,
    advantage: jax.Array,
    target: jax.Array,
    key: jax.Array,
    optimization: OptimizationSettings,
    squash_actions: bool,
) -> tuple[jax.Array, dict[str, jax.Array]]:
    """The loss of a minibatch and its parts: the policy's mean, log_std and value on the minibatch's
    observations, against the actions taken, their log-probabilities when collected, and the advantages
    (normalised here, per minibatch) and value targets."""
    log_prob = gaussian_log_prob(action, mean, log_std)
    log_ratio = log_prob - old_log_prob
    ratio = jnp.exp(log_ratio)
    advantage = (advantage - advantage.mean()) / (advantage.std() + 1e-8)
    clipped = jnp.clip(ratio, 1.0 - optimization.clip_epsilon, 1.0 + optimization.clip_epsilon)
    policy_loss = -jnp.minimum(ratio * advantage, clipped * advantage).mean()
    value_loss = 0.5 * jnp.square(value - target).mean()
    entropy = policy_entropy(mean, log_std, key, squash_actions)
    loss = policy_loss + optimization.value_coef * value_loss - optimization.entropy_coef * entropy
    return loss, {
        "loss": loss,
        "policy_loss": policy_loss,
        "value_loss": value_loss,
        "entropy": entropy,
        "action_std": jnp.exp(log_std).mean(),
        "approx_kl": ((ratio - 1.0) - log_ratio).mean(),
        "clip_fraction": (jnp.abs(ratio - 1.0) > optimization.clip_epsilon).mean(),
    }


def imitation_loss(
    mean: jax.Array, log_std: jax.Array, teacher_mean: jax.Array, teacher_log_std: jax.Array
) -> jax.Array:
    """KL(teacher || policy) of the two diagonal Gaussians, summed over action dimensions, averaged over the
    minibatch: the policy's mean is pulled to the teacher's, and its std to the teacher's where the teacher is sure."""
    kl = (
        log_std
        - teacher_log_std
        + 0.5 * (jnp.exp(2.0 * (teacher_log_std - log_std)) + jnp.square((teacher_mean - mean) * jnp.exp(-log_std)))
        - 0.5
    )
    return kl.sum(axis=-1).mean()
