"""`AntEnv` and `TrilegEnv`: the Isaac tasks as stable-baselines3 VecEnvs, ready for `PPO("MlpPolicy", env)`.

    from joshua_usd.tasks import AntEnv
    env = AntEnv(num_envs=1024, device="cuda")   # MJX on the GPUs JAX sees
    env = AntEnv(num_envs=16, device="cpu")      # mujoco.batch on a thread pool

`device="cuda"` runs the environments on MJX (joshua-mjx) on every GPU JAX sees, and is a ConfigError
saying so when JAX sees none (no silent fall-back to a CPU that is hundreds of times slower);
`device="cpu"` runs them on `mujoco.batch`. Either way the task is the registered one
(`isaac_ant_locomotion`, `isaac_trileg`) on its USD model, or on `model_path` when given.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from stable_baselines3.common.vec_env import VecEnv

from joshua_core.errors import ConfigError
from joshua_core.interfaces import EnvKind, EnvSpec
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_sb3 import SameStepVecEnv
from joshua_usd.backend import UsdBackend, mjx_backend

DEVICES = ("cuda", "cpu")


def AntEnv(  # noqa: N802 - named like the class it stands for in Isaac Lab
    num_envs: int = 1024, device: str = "cuda", *, seed: int = 0, model_path: str | Path | None = None
) -> VecEnv:
    """`isaac_ant_locomotion` on `num_envs` simulations as an SB3 VecEnv (see the module docstring)."""
    plugins = PluginHost.discover()  # a top-level entry, as Isaac Lab's AntEnv is
    return isaac_vec_env("isaac_ant_locomotion", num_envs, device, seed=seed, model_path=model_path, plugins=plugins)


def TrilegEnv(  # noqa: N802 - named like AntEnv
    num_envs: int = 1024, device: str = "cuda", *, seed: int = 0, model_path: str | Path | None = None
) -> VecEnv:
    """`isaac_trileg` on `num_envs` simulations as an SB3 VecEnv (see the module docstring)."""
    plugins = PluginHost.discover()  # a top-level entry, like AntEnv
    return isaac_vec_env("isaac_trileg", num_envs, device, seed=seed, model_path=model_path, plugins=plugins)


def isaac_vec_env(
    task: str,
    num_envs: int,
    device: str,
    *,
    seed: int = 0,
    model_path: str | Path | None = None,
    plugins: PluginHost,
) -> VecEnv:
    """Any registered task as an SB3 VecEnv on `device` ("cuda": MJX on the GPUs, "cpu": mujoco.batch)."""
    if device not in DEVICES:
        raise ConfigError(f"device must be one of {', '.join(DEVICES)}, got {device!r}")
    spec = EnvSpec(task, num_envs, seed=seed, model_path=resolve_data_path(model_path) if model_path else None)
    if device == "cpu":
        return SameStepVecEnv(UsdBackend().create_envs(spec, EnvKind.NUMPY, plugins))
    backend = mjx_backend()
    from joshua_usd.tasks.jax_vec_env import JaxVecEnv  # jax only for the GPU path

    spec = dataclasses.replace(spec, devices=gpu_devices())
    return JaxVecEnv(backend.create_envs(spec, EnvKind.JAX, plugins), seed)


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
