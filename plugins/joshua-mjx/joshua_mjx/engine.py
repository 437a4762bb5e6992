"""Models checked for MJX, and `MjxEngine`, one simulation stepped by MJX (the `mjx` backend's engine).

`MjxEngine` is a `MuJoCoEngine` whose physics runs through `mujoco.mjx` (jit-compiled on the
default JAX device); the host `MjData` is refreshed after every `step()`, so reading state,
sensors and rendering work exactly as with the `mujoco` backend. It is the way to check a model's
MJX behaviour against the CPU one; training uses the batched `joshua_mjx.env.MjxEnv` instead, which
`joshua_mjx.backend.MjxBackend.create_envs` makes (EnvKind.JAX).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import jax
import mujoco

from joshua_core.errors import ModelError
from joshua_core.interfaces import DEFAULT_RENDER_HEIGHT, DEFAULT_RENDER_WIDTH
from joshua_core.resources import resolve_data_path
from joshua_mjx.physics import mjx
from joshua_mujoco import MuJoCoEngine

if TYPE_CHECKING:
    from joshua_core.plugins import PluginHost

MJX_SUFFIX = "_mjx"


def mjx_variant(model_path: str | Path) -> Path:
    """The model file to simulate under MJX: `NAME_mjx.xml` beside `NAME.xml` when it exists (the
    MJX-compatible scene variant), else the file itself."""
    path = resolve_data_path(model_path)
    variant = path.with_name(f"{path.stem}{MJX_SUFFIX}{path.suffix}")
    return variant if not path.stem.endswith(MJX_SUFFIX) and variant.is_file() else path


def put_model(model: mujoco.MjModel, source: str | Path, device: jax.Device | None = None) -> mjx.Model:
    """MJX-JAX's `mjx.put_model` on `device` (default: this process's first device; MJX's own default,
    `jax.devices()[0]`, belongs to process 0 in a multi-process run), turning an MJX-unsupported feature into a
    ModelError that names the file and the fix."""
    try:
        return mjx.put_model(model, device=device or jax.local_devices()[0], impl="jax")
    except NotImplementedError as error:
        raise ModelError(
            f"{source}: the model uses something MJX does not support ({error}); use its MJX variant "
            f"(e.g. models/so_arm100/scene{MJX_SUFFIX}.xml) or MJX-supported geoms and options"
        ) from None


# What a user of the engine writes into the host MjData between steps; the rest of the device state
# (contacts, constraint rows, warm start) stays on the device from the previous step.
HOST_INPUTS = ("time", "qpos", "qvel", "act", "ctrl", "mocap_pos", "mocap_quat", "qfrc_applied", "xfrc_applied")


class MjxEngine(MuJoCoEngine):
    """One simulation whose `step()` runs MJX's physics (on the default JAX device)."""

    def __init__(
        self,
        model_path: str | Path,
        *,
        render_width: int = DEFAULT_RENDER_WIDTH,
        render_height: int = DEFAULT_RENDER_HEIGHT,
        plugins: PluginHost | None = None,
    ) -> None:
        super().__init__(model_path, render_width=render_width, render_height=render_height, plugins=plugins)
        self.mjx_model = put_model(self.model, model_path)
        self._device_data = mjx.make_data(self.mjx_model)
        self._step_n = jax.jit(self._physics_steps)

    def _physics_steps(self, data: mjx.Data, n: Any) -> mjx.Data:
        return jax.lax.fori_loop(0, n, lambda _, state: mjx.step(self.mjx_model, state), data)

    def step(self, n: int = 1) -> None:
        """`n` MJX steps from the current host state; the host `data` then holds the result."""
        inputs = {name: jax.numpy.asarray(getattr(self.data, name)) for name in HOST_INPUTS}
        self._device_data = self._step_n(self._device_data.replace(**inputs), n)
        mjx.get_data_into(self.data, self.model, self._device_data)
