"""The `usd` backend: robots described in USD (Isaac's format), or in any format a plugin reads
(`joshua_mujoco.read_spec`), MJCF included, on MuJoCo physics (the default) or PhysX.

Engines are joshua-mujoco's `MuJoCoEngine`; JAX environments joshua-mjx's (an optional dependency,
imported only then). NUMPY environments are joshua-mujoco's `mujoco.batch` ones. With
`training.usd { physics: PHYSX }` both kinds step on PhysX (`joshua_usd.physx`, `joshua_usd.physx_jax`):
the model is written to USD by our exporter first when it is not a stage already.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.interfaces import DEFAULT_RENDER_HEIGHT, DEFAULT_RENDER_WIDTH, Backend, EnvKind, EnvSpec
from joshua_mujoco import MuJoCoBackend, MuJoCoEngine

if TYPE_CHECKING:
    from joshua_core.plugins import PluginHost

MJX_MISSING = (
    "backend usd: JAX environments need joshua-mjx, which is not installed; "
    "install joshua-mjx (pip install 'joshua-usd[mjx]')"
)


class UsdBackend(Backend):
    """The `usd` backend: a MuJoCoEngine per model; NUMPY (mujoco.batch or PhysX) and JAX (MJX or PhysX)
    environments."""

    def create_engine(
        self,
        model_path: Path,
        plugins: PluginHost,
        *,
        render_width: int = DEFAULT_RENDER_WIDTH,
        render_height: int = DEFAULT_RENDER_HEIGHT,
    ) -> MuJoCoEngine:
        return MuJoCoEngine(model_path, render_width=render_width, render_height=render_height, plugins=plugins)

    def create_envs(self, spec: EnvSpec, kind: EnvKind, plugins: PluginHost) -> Any:
        if uses_physx(spec.training):
            return physx_envs(spec, kind, plugins)
        if kind is EnvKind.NUMPY:
            return MuJoCoBackend().create_envs(spec, kind, plugins)
        return mjx_backend().create_envs(spec, kind, plugins)


def uses_physx(training: TrainingConfig | None) -> bool:
    """Whether `training.usd.physics` is PHYSX (MuJoCo where the config names none)."""
    from joshua_usd.options_pb2 import UsdOptions, usd

    return training is not None and training.Extensions[usd].physics == UsdOptions.PHYSX


def physx_envs(spec: EnvSpec, kind: EnvKind, plugins: PluginHost) -> Any:
    """The task on PhysX: joshua-mujoco's BatchedVectorEnv (NUMPY, `joshua_usd.physx`, reset with the spec's
    seed) or joshua-mjx's MjxEnv (JAX, `joshua_usd.physx_jax`); the model is written to USD first when it is
    not a stage."""
    from joshua_core.resources import resolve_data_path
    from joshua_core.tasks import load_task_spec
    from joshua_mujoco import BatchedSimulation, BatchedVectorEnv, load_task_model
    from joshua_usd.exporter import export_model
    from joshua_usd.physx import PhysxBatchPhysics
    from joshua_usd.plugin import USD_SUFFIXES

    task, model = load_task_model(spec.task, spec.model_path, plugins, spec.task_config)
    path = spec.model_path or resolve_data_path(load_task_spec(spec.task, plugins).model_path)
    with tempfile.TemporaryDirectory(prefix="joshua-physx-") as folder:
        if path.suffix.lower() not in USD_SUFFIXES:
            path = export_model(path, Path(folder) / f"{path.stem}.usda")
        if kind is not EnvKind.NUMPY:
            mjx_backend()  # says what to install where joshua-mjx is missing
            from joshua_usd.physx_jax import physx_device_envs

            return physx_device_envs(spec, path, task, model)
        physics = PhysxBatchPhysics(model, path, spec.num_envs, task.fields)
    simulation = BatchedSimulation(
        task, model, spec.num_envs, seed=spec.seed, physics=physics, curriculum=spec.curriculum
    )
    env = BatchedVectorEnv(simulation, desync_episodes=spec.desync_episodes)
    env.reset(seed=spec.seed)
    return env


def mjx_backend() -> Backend:
    """joshua-mjx's backend, or a one-line ConfigError saying to install it."""
    try:
        from joshua_mjx import MjxBackend
    except ModuleNotFoundError as error:
        if error.name != "joshua_mjx":
            raise
        raise ConfigError(MJX_MISSING) from None
    return MjxBackend()
