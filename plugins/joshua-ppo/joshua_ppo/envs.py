"""The environments PPO trains on: EnvKind.JAX environments from the backend the training config names
(`mjx`, or any other backend that provides that kind), asked for in one place for the whole package.

PPO needs `reset(key)`, `step(state, action)`, `redraw_starts(state)`, the sizes, the task, the model
and the device mesh the environments are spread over (its one axis is the one gradients are averaged on);
`joshua_core.interfaces.EnvKind` documents them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.interfaces import EnvKind
from joshua_core.run_context import RunContext

__all__ = ["DEFAULT_NUM_ENVS", "EnvState", "JaxEnv", "environment", "env_axis"]

JaxEnv = Any  # an EnvKind.JAX environment (e.g. joshua_mjx.MjxEnv)
EnvState = Any  # the state pytree of one (e.g. joshua_mjx.EnvState)
DEFAULT_NUM_ENVS = 2048  # when training.num_envs is 0


def env_axis(env: JaxEnv) -> str:
    """The name of the device-mesh axis the environments are spread over."""
    (axis,) = env.mesh.axis_names
    return axis


def environment(
    config: TrainingConfig,
    context: RunContext,
    num_envs: int | None = None,
    devices: Sequence[Any] | None = None,
    *,
    training_envs: bool = False,
) -> JaxEnv:
    """The JAX environments of a training config's task, model and task_config, from its backend: `num_envs`
    of them (default: the config's num_envs, else DEFAULT_NUM_ENVS), over `devices` (default: every visible
    device, those of every process in a multi-process run). `training_envs`: the ones PPO learns on, whose
    episodes are desynchronised (see RunContext.create_envs)."""
    count = num_envs if num_envs is not None else config.num_envs or DEFAULT_NUM_ENVS
    return context.create_envs(config, EnvKind.JAX, num_envs=count, devices=devices, training_envs=training_envs)
