"""Any registered task as a stable-baselines3 VecEnv, ready for `PPO("MlpPolicy", env)`.

    from joshua_sb3 import AntEnv, task_vec_env
    env = AntEnv(num_envs=1024, device="cuda")   # the task whose alias is AntEnv, MJX on the GPUs JAX sees
    env = task_vec_env("so_arm100_reach", 16, device="cpu")   # mujoco.batch on a thread pool

`device="cuda"` runs the environments on MJX (the default training backend) on every GPU JAX sees, and
is a ConfigError saying so when JAX sees none (no silent fall-back to a CPU that is hundreds of times
slower); `device="cpu"` runs them on `mujoco.batch` (the default simulation backend). The task is the
registered one on its own model, or on `model_path` when given (any format a plugin reads, USD included).
A task's aliases (`TaskSpec.aliases`, declared by the plugin that provides it, e.g. Isaac Lab's `AntEnv`) are
names of this package: `alias_env` makes the factory, so this plugin names no other plugin's tasks.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

from stable_baselines3.common.vec_env import VecEnv

from joshua_core.defaults import DEFAULT_SIMULATION_BACKEND, DEFAULT_TRAINING_BACKEND
from joshua_core.errors import ConfigError
from joshua_core.interfaces import EnvKind, EnvSpec
from joshua_core.kinds import Kind
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_core.tasks import load_task_spec
from joshua_sb3.vec_env import SameStepVecEnv

# Per device: the environments' kind and the core's default backend that provides them.
DEVICES = {"cuda": (EnvKind.JAX, DEFAULT_TRAINING_BACKEND), "cpu": (EnvKind.NUMPY, DEFAULT_SIMULATION_BACKEND)}

TaskEnvFactory = Callable[..., VecEnv]


def alias_env(alias: str) -> TaskEnvFactory:
    """`AntEnv(num_envs=1024, device="cuda", *, seed=0, model_path=None)`: the VecEnv factory of the installed task
    that declares `alias` among its aliases. A name no task declares is an AttributeError, as for any missing
    attribute of the package. A top-level entry point (`from joshua_sb3 import AntEnv`): it finds the plugins."""
    plugins = PluginHost.discover()
    for task in plugins.names(Kind.TASK):
        if alias in load_task_spec(task, plugins).aliases:
            return _task_env(task, alias, plugins)
    raise AttributeError(
        f"module 'joshua_sb3' has no attribute '{alias}': no installed task has it as an alias "
        "(`joshua plugins` lists the tasks; task_vec_env takes any of them by name)"
    )


def _task_env(task: str, alias: str, plugins: PluginHost) -> TaskEnvFactory:
    """`task` under the name `alias` as a function of the environments' number, device, seed and model."""

    def make(
        num_envs: int = 1024, device: str = "cuda", *, seed: int = 0, model_path: str | Path | None = None
    ) -> VecEnv:
        return task_vec_env(task, num_envs, device, seed=seed, model_path=model_path, plugins=plugins)

    make.__name__ = make.__qualname__ = alias
    make.__doc__ = f"`{task}` on `num_envs` simulations as an SB3 VecEnv (see joshua_sb3.task_envs)."
    return make


def task_vec_env(
    task: str,
    num_envs: int,
    device: str,
    *,
    seed: int = 0,
    model_path: str | Path | None = None,
    plugins: PluginHost | None = None,
) -> VecEnv:
    """Any registered task as an SB3 VecEnv on `device` ("cuda": MJX on the GPUs, "cpu": mujoco.batch)."""
    if device not in DEVICES:
        raise ConfigError(f"device must be one of {', '.join(DEVICES)}, got {device!r}")
    plugins = plugins or PluginHost.discover()
    kind, backend = DEVICES[device]
    spec = EnvSpec(task, num_envs, seed=seed, model_path=resolve_data_path(model_path) if model_path else None)
    if kind is EnvKind.NUMPY:
        return SameStepVecEnv(plugins.backend(backend).create_envs(spec, kind, plugins))
    from joshua_sb3.jax_vec_env import JaxVecEnv  # jax only for the GPU path

    spec = dataclasses.replace(spec, devices=gpu_devices())
    return JaxVecEnv(plugins.backend(backend).create_envs(spec, kind, plugins), seed)


def gpu_devices() -> list[Any]:
    """The GPUs JAX sees; a ConfigError naming what it sees instead when there are none."""
    import jax

    try:
        return jax.devices("gpu")
    except RuntimeError:
        seen = ", ".join(str(device) for device in jax.devices())
        raise ConfigError(
            f'device="cuda": JAX sees no GPU (only {seen}); use device="cpu" (mujoco.batch), '
            "or install JAX with CUDA (pip install 'jax[cuda12]')"
        ) from None
