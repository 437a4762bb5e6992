"""The off-policy losses (critic regression to clipped double-Q targets, TD3's and SAC's actor losses, SAC's
temperature), as plain functions of the networks' outputs; applying the networks is the iteration's job."""

from __future__ import annotations

import jax
import jax.numpy as jnp


def critic_target(
    reward: jax.Array, discount: jax.Array, next_q: jax.Array, next_log_prob: jax.Array | None = None,
    alpha: jax.Array | None = None,
) -> jax.Array:  # fmt: skip
    """r + discount x (min over the two target critics' Q of the next action, less alpha log pi for SAC), no
    gradient: `reward` the n-step sum, `discount` gamma^m or 0 (`joshua_ppo.replay.n_step_return`)."""
    future = next_q.min(axis=0)
    if next_log_prob is not None and alpha is not None:
        future = future - alpha * next_log_prob
    return jax.lax.stop_gradient(reward + discount * future)


def critic_loss(q: jax.Array, target: jax.Array) -> jax.Array:
    """Half the squared error of both critics (2, batch) to the target (batch), summed over critics."""
    return 0.5 * jnp.square(q - target[None]).sum(axis=0).mean()


def td3_actor_loss(q: jax.Array) -> jax.Array:
    """TD3's actor maximises the critics' value of its own actions (the smaller of the two, as its target)."""
    return -q.min(axis=0).mean()


def sac_actor_loss(q: jax.Array, log_prob: jax.Array, alpha: jax.Array) -> jax.Array:
    """SAC's actor maximises value plus entropy: E[alpha log pi(a|s) - min Q(s, a)], a drawn from the policy."""
    return (jax.lax.stop_gradient(alpha) * log_prob - q.min(axis=0)).mean()


def temperature_loss(log_alpha: jax.Array, log_prob: jax.Array, target_entropy: float) -> jax.Array:
    """SAC's temperature rises while the policy's entropy (-log pi) is below the target, falls while above."""
    return -(log_alpha * jax.lax.stop_gradient(log_prob + target_entropy)).mean()
