"""Advantages and value targets over unrolls: GAE (Schulman et al.) or the TD error towards the lambda-return."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from joshua_ppo.batches import Transition, Unroll
from joshua_ppo.settings import ReturnSettings


def estimate_advantages(
    returns: ReturnSettings, value: jax.Array, last_value: jax.Array, steps: Transition | Unroll
) -> tuple[jax.Array, jax.Array]:
    """Advantages and value targets (lambda-returns) over unrolls, time-major: value (T, N) estimated before
    each step, last_value (N,) after the last; the trace is cut where an episode ended, a terminated
    episode bootstraps from zero and a truncated one from the value of its final observation."""
    next_values = jnp.concatenate([value[1:], last_value[None]], axis=0)
    bootstrap = jnp.where(steps.truncated, steps.final_value, jnp.where(steps.terminated, 0.0, next_values))
    deltas = steps.reward + returns.gamma * bootstrap - value
    continues = 1.0 - (steps.terminated | steps.truncated).astype(jnp.float32)

    def backward(carry: jax.Array, step: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
        delta, cont = step
        advantage = delta + returns.gamma * returns.gae_lambda * cont * carry
        return advantage, advantage

    # unrolled: a few steps of a few elementwise ops, which a loop would launch one kernel at a time
    # (on every minibatch, with recompute_advantages)
    _, advantage = jax.lax.scan(
        backward, jnp.zeros_like(last_value), (deltas, continues), reverse=True, unroll=min(value.shape[0], 16)
    )
    target = advantage + value
    if returns.advantage == "lambda_return":  # delta_t + gamma (G_{t+1} - V(s_{t+1})) within the episode
        next_advantage = jnp.concatenate([advantage[1:], jnp.zeros_like(last_value)[None]], axis=0)
        advantage = deltas + returns.gamma * continues * next_advantage
    return advantage, target
