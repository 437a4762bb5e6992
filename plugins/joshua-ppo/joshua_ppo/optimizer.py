"""The optimiser (Adam after optional gradient clipping) and the two learning-rate schedules it can follow."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import optax

from joshua_ppo.settings import LEARNING_RATE_BOUNDS, OptimizationSettings


def make_optimizer(optimization: OptimizationSettings) -> optax.GradientTransformation:
    """Adam after optional global-norm clipping, with the learning rate in its state (the adaptive schedule sets it)."""

    def chain(learning_rate: float) -> optax.GradientTransformation:
        adam = optax.adam(learning_rate)
        if optimization.max_grad_norm is None:
            return adam
        return optax.chain(optax.clip_by_global_norm(optimization.max_grad_norm), adam)

    return optax.inject_hyperparams(chain)(learning_rate=optimization.learning_rate)


def adapt_learning_rate(learning_rate: jax.Array, kl: jax.Array, desired_kl: float) -> jax.Array:
    """The adaptive schedule of rsl_rl (Isaac Lab's PPO): divide the learning rate by 1.5 when the KL
    divergence from the collecting policy exceeds twice the desired one, multiply it by 1.5 when it is
    below half, within LEARNING_RATE_BOUNDS. Steps stay small where the policy is sharp (a small std makes
    every change of the mean a large change of the distribution) and grow where it barely moves."""
    lower, upper = LEARNING_RATE_BOUNDS
    # not on a KL of 0: the first step after collecting, before the policy has moved
    faster = jnp.where((kl > 0) & (kl < desired_kl / 2.0), jnp.minimum(learning_rate * 1.5, upper), learning_rate)
    return jnp.where(kl > desired_kl * 2.0, jnp.maximum(learning_rate / 1.5, lower), faster)


def scheduled_learning_rate(
    opt_state: optax.OptState,
    kl: jax.Array | None,
    optimization: OptimizationSettings,
    env_steps_per_gradient_step: float,
) -> optax.OptState:
    """The optimiser state with the learning rate of this gradient step: adapted to `kl` (every device's
    mean KL before this step; None unless desired_kl is set), annealed by the optimiser's step count in
    environment steps when anneal_steps is set; unchanged otherwise."""
    if kl is not None:
        learning_rate = adapt_learning_rate(opt_state.hyperparams["learning_rate"], kl, optimization.desired_kl)
        opt_state = opt_state._replace(hyperparams={**opt_state.hyperparams, "learning_rate": learning_rate})
    if optimization.anneal_steps > 0:
        progress = opt_state.count * env_steps_per_gradient_step / optimization.anneal_steps
        learning_rate = optimization.learning_rate * jnp.maximum(1.0 - progress, 0.0)
        opt_state = opt_state._replace(hyperparams={**opt_state.hyperparams, "learning_rate": learning_rate})
    return opt_state
