"""The environments PPO trains on: MJX's functional batched environment, in one place for the whole package.

PPO needs `reset(key)`, `step(state, action)`, `redraw_starts(state)`, the sizes, the task, the model
and the device mesh the environments are spread over (its one axis is the one gradients are averaged on).
"""

from __future__ import annotations

import jax

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.plugins import PluginHost
from joshua_mjx.env import EnvState, MjxEnv, make_mjx_env

__all__ = ["EnvState", "MjxEnv", "environment", "env_axis"]


def env_axis(env: MjxEnv) -> str:
    """The name of the device-mesh axis the environments are spread over."""
    (axis,) = env.mesh.axis_names
    return axis


def environment(
    config: TrainingConfig, plugins: PluginHost | None, num_envs: int, devices: list[jax.Device] | None = None
) -> MjxEnv:
    """The MJX environment of a training config's task, model and task_config, over `devices` (default: all)."""
    if config.backend and config.backend != "mjx":
        raise ConfigError(f"trainer ppo runs on the backend 'mjx', not '{config.backend}'")
    if not config.task:
        raise ConfigError('training.task is empty; name a task, e.g. task: "ant_locomotion" (see `joshua plugins`)')
    return make_mjx_env(
        config.task,
        num_envs,
        model_path=config.model_path or None,
        plugins=plugins,
        task_config=config.task_config if config.HasField("task_config") else None,
        devices=devices,
    )
