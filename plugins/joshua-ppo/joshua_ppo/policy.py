"""The policy: the actor-critic network its settings describe, and the actions the environment gets from it."""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from joshua_ppo.envs import JaxEnv
from joshua_ppo.networks import ActorCritic, SeparateActorCritic
from joshua_ppo.normalizer import RunningStatistics, normalize
from joshua_ppo.settings import NetworkSettings


def make_network(env: JaxEnv, network: NetworkSettings) -> ActorCritic | SeparateActorCritic:
    """The actor-critic network for the environment's action size."""
    shape = {"activation": network.activation, "state_dependent_std": network.state_dependent_std}
    if network.value_hidden_sizes:
        return SeparateActorCritic(
            env.action_size, tuple(network.hidden_sizes), tuple(network.value_hidden_sizes), **shape
        )
    return ActorCritic(action_dim=env.action_size, hidden_sizes=tuple(network.hidden_sizes), **shape)


def env_actions(sample: jax.Array, network: NetworkSettings) -> jax.Array:
    """What the environment gets for a policy sample (or mean): squashed by tanh, or as is (the env clips)."""
    return jnp.tanh(sample) if network.squash_actions else sample


def policy_actions(
    net: ActorCritic | SeparateActorCritic,
    params: Any,
    stats: RunningStatistics,
    observation: jax.Array,
    network: NetworkSettings,
) -> jax.Array:
    """The deterministic policy's actions (the Gaussian's mean, squashed when the policy squashes)."""
    mean, _, _ = net.apply({"params": params}, normalize(stats, observation, network.normalize_observations))
    return env_actions(mean, network)
