"""Any registered task as a stable-baselines3 VecEnv, ready for `PPO("MlpPolicy", env)`.

    from joshua_sb3 import AntEnv, task_vec_env
    env = AntEnv(num_envs=1024, device="cuda")   # joshua-usd's isaac_ant_locomotion, MJX on the GPUs JAX sees
    env = task_vec_env("so_arm100_reach", 16, device="cpu")   # mujoco.batch on a thread pool

`device="cuda"` runs the environments on MJX (the backend of `framework: MJX`) on every GPU JAX sees, and
is a ConfigError saying so when JAX sees none (no silent fall-back to a CPU that is hundreds of times
slower); `device="cpu"` runs them on `mujoco.batch` (the backend of `framework: SB3`). The task is the
registered one on its own model, or on `model_path` when given (any format a plugin reads, USD included).
`AntEnv` and `TrilegEnv` are Isaac Lab's names for the Isaac tasks joshua-usd registers.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from stable_baselines3.common.vec_env import VecEnv

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.defaults import training_plugins
from joshua_core.errors import ConfigError
from joshua_core.interfaces import EnvKind, EnvSpec
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_sb3.vec_env import SameStepVecEnv

# Per device: the environments' kind and the framework whose default backend provides them.
DEVICES = {"cuda": (EnvKind.JAX, TrainingConfig.MJX), "cpu": (EnvKind.NUMPY, TrainingConfig.SB3)}


def AntEnv(  # noqa: N802 - named like the class it stands for in Isaac Lab
    num_envs: int = 1024, device: str = "cuda", *, seed: int = 0, model_path: str | Path | None = None
) -> VecEnv:
    """`isaac_ant_locomotion` (joshua-usd) on `num_envs` simulations as an SB3 VecEnv (see the module docstring)."""
    return task_vec_env("isaac_ant_locomotion", num_envs, device, seed=seed, model_path=model_path)


def TrilegEnv(  # noqa: N802 - named like AntEnv
    num_envs: int = 1024, device: str = "cuda", *, seed: int = 0, model_path: str | Path | None = None
) -> VecEnv:
    """`isaac_trileg` (joshua-usd) on `num_envs` simulations as an SB3 VecEnv (see the module docstring)."""
    return task_vec_env("isaac_trileg", num_envs, device, seed=seed, model_path=model_path)


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
    kind, framework = DEVICES[device]
    _, backend = training_plugins(TrainingConfig(framework=framework))
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
