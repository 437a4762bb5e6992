"""What PPO's networks cost per environment step of a preset: rollout inference against the update, as XLA counts it.

    python bench/ppo_network_cost.py                             # ant_train_mjx_tuned; seconds on a CPU
    python bench/ppo_network_cost.py --preset trileg_train_mjx

Compiles (runs nothing) the network work of the compiled iteration (`joshua_ppo.iteration`) at the preset's
batch sizes: in the rollout, the policy on each observation and the value on each final observation, and on
each observation unless advantages are recomputed (what is left of the two actor-critic evaluations per step
once JAX drops the outputs nobody reads; plugins/joshua-ppo/tests/test_iteration_work.py checks that), and in
the update the gradient of one minibatch's loss, recomputed advantages included. Prints XLA's cost analysis
(FLOPs and bytes accessed) per environment step (the update's times num_epochs, as every transition is learnt
from once per epoch) and per iteration. The bytes follow the CPU compiler's fusions: likely more than a GPU
moves, whose matrix-multiplication kernels apply the bias and activation too.
"""

from __future__ import annotations

import argparse
from typing import Any

import jax
import jax.numpy as jnp
from mjx_time_to_target import environment, load_config

from joshua_core.options import options_of
from joshua_core.plugins import PluginHost
from joshua_ppo import options_pb2
from joshua_ppo.batches import Sample, Unroll
from joshua_ppo.config_settings import ppo_settings
from joshua_ppo.iteration import _Iteration
from joshua_ppo.normalizer import fresh_statistics


def cost(function: Any, *shapes: Any) -> tuple[float, float]:
    """(FLOPs, bytes accessed) of `function` compiled for arguments of these shapes."""
    analysis = jax.jit(function).lower(*shapes).compile().cost_analysis()
    analysis = analysis[0] if isinstance(analysis, list) else analysis
    return analysis["flops"], analysis["bytes accessed"]


def minibatch_shapes(steps: _Iteration, size: int, obs: int, act: int) -> Sample | Unroll:
    """One minibatch of `size` transitions, as the update gets it (whole unrolls when recomputing advantages)."""

    def shape(*dims: int, dtype: Any = jnp.float32) -> jax.ShapeDtypeStruct:
        return jax.ShapeDtypeStruct(dims, dtype)

    if not steps.recompute:
        return Sample(shape(size, obs), None, None, shape(size, act), shape(size), shape(size), shape(size))
    unrolls, length = size // steps.rollout.num_steps, steps.rollout.num_steps
    per_step, flags = shape(unrolls, length), shape(unrolls, length, dtype=jnp.bool_)
    observations, actions = shape(unrolls, length, obs), shape(unrolls, length, act)
    return Unroll(
        observations, None, None, actions, per_step, per_step, flags, flags, per_step, shape(unrolls, obs), None
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", default="ant_train_mjx_tuned")
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE", help="override a preset field")
    args = parser.parse_args()
    plugins = PluginHost.discover()
    config = load_config(args.preset, args.set, None, plugins.options())
    settings = ppo_settings(options_of(config, options_pb2.ppo), config)
    env = environment(config, plugins, None, jax.devices()[:1])  # made, never reset
    num_envs = env.num_envs
    steps = _Iteration(env, settings.rollout, settings.optimization, settings.returns, settings.network)
    obs, act = env.observation_size, env.action_size
    params = jax.eval_shape(lambda: steps.net.init(jax.random.PRNGKey(0), jnp.zeros((1, obs)))["params"])
    stats = fresh_statistics(obs)

    def rollout(params: Any, observation: jax.Array, final_observation: jax.Array) -> tuple[jax.Array, ...]:
        mean, log_std, value = steps.apply(params, stats, observation, None)
        kept = (mean, log_std) if steps.recompute else (mean, log_std, value)  # the update recomputes the value
        return *kept, steps.apply(params, stats, final_observation, None)[2]

    def gradient(params: Any, batch: Sample | Unroll, key: jax.Array) -> Any:
        return jax.grad(steps.loss, has_aux=True)(params, stats, batch, key)

    batch = jax.ShapeDtypeStruct((num_envs, obs), jnp.float32)
    rollout_flops, rollout_bytes = (value / num_envs for value in cost(rollout, params, batch, batch))
    size, epochs = settings.optimization.minibatch_size, settings.optimization.num_epochs
    minibatch = minibatch_shapes(steps, size, obs, act)
    key = jax.random.PRNGKey(0)
    update_flops, update_bytes = (value / size * epochs for value in cost(gradient, params, minibatch, key))
    per_iteration = num_envs * settings.rollout.num_steps * settings.rollout.unrolls_per_iteration
    print(f"{args.preset}: observation {obs}, action {act}, {per_iteration:,} env steps per iteration")
    for name, flops, traffic in (("rollout", rollout_flops, rollout_bytes), ("update", update_flops, update_bytes)):
        print(
            f"{name:8s} {flops / 1e6:6.2f} MFLOP {traffic / 1e3:6.0f} kB per env step;"
            f" {flops * per_iteration / 1e12:6.3f} TFLOP {traffic * per_iteration / 1e9:6.1f} GB per iteration"
        )


if __name__ == "__main__":
    main()
