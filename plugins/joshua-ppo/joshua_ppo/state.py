"""The training state (parameters, optimiser, normaliser, environments, key), its counters, and where it lives."""

from __future__ import annotations

from typing import Any, NamedTuple

import jax

from joshua_ppo.envs import EnvState, JaxEnv
from joshua_ppo.normalizer import RunningStatistics, fresh_statistics
from joshua_ppo.optimizer import make_optimizer
from joshua_ppo.policy import init_params
from joshua_ppo.settings import NetworkSettings, OptimizationSettings


class TrainingState(NamedTuple):
    """Everything one iteration changes: parameters, optimiser, normaliser, environments, random key."""

    params: Any
    opt_state: Any
    normalizer: RunningStatistics
    env_state: EnvState
    key: jax.Array


class Progress(NamedTuple):
    """Counters that live outside the compiled iteration (and in checkpoints)."""

    iteration: int
    env_steps: int


def init_state(
    env: JaxEnv, *, seed: int, network: NetworkSettings, optimization: OptimizationSettings
) -> TrainingState:
    """Fresh parameters, optimiser and normaliser, and freshly reset environments."""
    key = jax.random.PRNGKey(seed)
    key, init_key, reset_key = jax.random.split(key, 3)
    params = init_params(env, network, init_key)
    normalizer = fresh_statistics(env.observation_size)
    state = TrainingState(params, make_optimizer(optimization).init(params), normalizer, env.reset(reset_key), key)
    return jax.device_put(state, state_shardings(env))


def state_shardings(env: JaxEnv) -> TrainingState:
    """Where a training state lives (a prefix of its tree): environments split over devices, the rest replicated."""
    return TrainingState(env.replicated, env.replicated, env.replicated, env.sharding, env.replicated)


def abstract_state(env: JaxEnv, *, network: NetworkSettings, optimization: OptimizationSettings) -> TrainingState:
    """Shapes, dtypes and shardings of `init_state`'s result, computing nothing: enough to compile the iteration."""
    shapes = jax.eval_shape(lambda: init_state(env, seed=0, network=network, optimization=optimization))

    def placed(sharding: jax.sharding.Sharding, subtree: Any) -> Any:
        return jax.tree.map(lambda leaf: jax.ShapeDtypeStruct(leaf.shape, leaf.dtype, sharding=sharding), subtree)

    return jax.tree.map(placed, state_shardings(env), shapes)
