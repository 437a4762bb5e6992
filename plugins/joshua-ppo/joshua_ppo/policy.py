"""The policy: the actor-critic network its settings describe, its inputs, and the actions the environment gets
from it."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from joshua_core.errors import ConfigError
from joshua_ppo.envs import EnvState, JaxEnv
from joshua_ppo.networks import ActorCritic, PixelActorCritic, SeparateActorCritic
from joshua_ppo.normalizer import RunningStatistics, normalize
from joshua_ppo.settings import NetworkSettings, PixelSettings

Network = ActorCritic | SeparateActorCritic | PixelActorCritic
POLICY_CAMERA_KINDS = ("rgb", "depth")  # images an encoder reads as intensities (segmentation ids are labels)


def make_network(env: JaxEnv, network: NetworkSettings) -> Network:
    """The actor-critic network for the environment's action size (and, for a pixel policy, its cameras and
    observation terms: a ConfigError names one the task lacks)."""
    shape: dict[str, Any] = {"activation": network.activation, "state_dependent_std": network.state_dependent_std}
    if network.pixels is not None:
        return PixelActorCritic(
            env.action_size,
            tuple(network.hidden_sizes),
            tuple(network.value_hidden_sizes or network.hidden_sizes),
            network.pixels,
            observation_indices(env, network.pixels),
            **shape,
        )
    if network.value_hidden_sizes:
        return SeparateActorCritic(
            env.action_size, tuple(network.hidden_sizes), tuple(network.value_hidden_sizes), **shape
        )
    return ActorCritic(action_dim=env.action_size, hidden_sizes=tuple(network.hidden_sizes), **shape)


def observation_indices(env: JaxEnv, pixels: PixelSettings, owner: str = "training.ppo") -> tuple[int, ...]:
    """The flat observation's entries the pixel policy sees (its observation terms'), after checking its cameras
    and commands against the task's (a ConfigError names the option of the trainer at `owner` that is wrong)."""
    cameras = {camera.name: camera for camera in env.task.cameras}
    for name in pixels.cameras:
        if name not in cameras:
            known = ", ".join(cameras) or "none: add them to task_config.cameras"
            raise ConfigError(f"{owner}.pixels: camera '{name}' is not one of the task's cameras ({known})")
        if cameras[name].kind not in POLICY_CAMERA_KINDS:
            raise ConfigError(
                f"{owner}.pixels: camera '{name}' is a {cameras[name].kind} camera; "
                f"the policy reads {' or '.join(POLICY_CAMERA_KINDS)}"
            )
    for name in pixels.commands:
        if name not in env.task.commands:
            known = ", ".join(env.task.commands) or "none"
            raise ConfigError(f"{owner}.pixels: command '{name}' is not one of the task's commands ({known})")
    layout = env.task.observation_layout
    starts = np.cumsum([0, *(width for _, width in layout)])
    spans = {name: range(start, start + width) for (name, width), start in zip(layout, starts, strict=False)}
    for name in pixels.observation_terms:
        if name not in spans:
            raise ConfigError(
                f"{owner}.pixels: observation term '{name}' is not one of the task's ({', '.join(spans)})"
            )
    names = pixels.observation_terms or tuple(spans)
    return tuple(int(index) for name in names for index in spans[name])


def policy_views(state: EnvState, network: NetworkSettings) -> dict[str, dict[str, jax.Array]] | None:
    """What a pixel policy sees of the environment state beside the observation: {"images": by camera, "commands":
    by command} (None for a policy without pixels)."""
    return camera_views(state, network.pixels)


def camera_views(state: EnvState, pixels: PixelSettings | None) -> dict[str, dict[str, jax.Array]] | None:
    """The views of the environment state that `pixels` names (None without pixels): see `policy_views`."""
    if pixels is None:
        return None
    return {
        "images": {name: state.images[name] for name in pixels.cameras},
        "commands": {name: state.commands[name] for name in pixels.commands},
    }


def init_params(env: JaxEnv, network: NetworkSettings, key: jax.Array) -> Any:
    """Fresh parameters of the network for the environment's observation (and images)."""
    observation = jnp.zeros((1, env.observation_size))
    if network.pixels is None:
        return make_network(env, network).init(key, observation)["params"]
    net = make_network(env, network)  # checks the cameras and commands first
    cameras = {camera.name: camera for camera in env.task.cameras}
    views = {
        "images": {name: jnp.zeros((1, *cameras[name].shape), cameras[name].dtype) for name in network.pixels.cameras},
        "commands": {name: jnp.zeros((1, env.task.commands[name])) for name in network.pixels.commands},
    }
    return net.init(key, observation, None, views)["params"]


def image_bytes_per_env(env: JaxEnv, network: NetworkSettings) -> int:
    """Bytes of the images one environment's step adds to the rollout buffer (0 without pixels)."""
    if network.pixels is None:
        return 0
    cameras = {camera.name: camera for camera in env.task.cameras}
    return sum(cameras[name].bytes_per_env for name in network.pixels.cameras)


def env_actions(sample: jax.Array, network: NetworkSettings) -> jax.Array:
    """What the environment gets for a policy sample (or mean): squashed by tanh, or as is (the env clips)."""
    return jnp.tanh(sample) if network.squash_actions else sample


def policy_actions(
    net: Network,
    params: Any,
    stats: RunningStatistics,
    observation: jax.Array,
    network: NetworkSettings,
    views: dict[str, dict[str, jax.Array]] | None = None,
) -> jax.Array:
    """The deterministic policy's actions (the Gaussian's mean, squashed when the policy squashes); `views`: what a
    pixel policy sees beside the observation (`policy_views`)."""
    observation = normalize(stats, observation, network.normalize_observations)
    inputs = (observation,) if views is None else (observation, None, views)
    mean, _, _ = net.apply({"params": params}, *inputs)  # type: ignore[misc]  # without mutable, apply gives the output alone
    return env_actions(mean, network)


def deterministic_policy(
    env: JaxEnv, network: NetworkSettings
) -> Callable[[Any, RunningStatistics, EnvState], jax.Array]:
    """The deterministic policy of the network `network` describes, as rollouts take it: (params, normaliser,
    environment state) -> the environment's actions."""
    net = make_network(env, network)

    def act(params: Any, stats: RunningStatistics, state: EnvState) -> jax.Array:
        return policy_actions(net, params, stats, state.observation, network, policy_views(state, network))

    return act
