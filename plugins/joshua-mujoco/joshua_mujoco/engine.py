"""`MuJoCoEngine`: the MjModel + MjData lifecycle, stepping, controls, sensors and headless rendering."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from joshua_render import choose_headless_gl

choose_headless_gl()  # must run before mujoco is imported: mujoco picks its GL platform at import

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from numpy.typing import ArrayLike, NDArray  # noqa: E402

from joshua_core.errors import ConfigError  # noqa: E402
from joshua_core.interfaces import DEFAULT_RENDER_HEIGHT, DEFAULT_RENDER_WIDTH, Backend, Engine, EnvKind, EnvSpec  # noqa: E402
from joshua_core.plugins import PluginHost  # noqa: E402
from joshua_core.resources import resolve_data_path  # noqa: E402
from joshua_mujoco.models import MJCF_SUFFIXES, compile_model  # noqa: E402
from joshua_render import camera_id, create_renderer  # noqa: E402

if TYPE_CHECKING:
    from joshua_mujoco.vector import BatchedVectorEnv

# MuJoCo warnings that mean the state went non-finite (MuJoCo then silently resets the data).
_INSTABILITY_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQACC,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADCTRL,
)


class MuJoCoEngine(Engine):
    """One MuJoCo simulation: `model` (MjModel), `data` (MjData) and the `Engine` methods (README's example).

    Load from a file (`model_path`, relative paths also resolve against the shipped models) or from
    an XML string (`xml`, with optional in-memory `assets` such as meshes keyed by file name).
    """

    def __init__(
        self,
        model_path: str | Path | None = None,
        *,
        xml: str | None = None,
        assets: Mapping[str, bytes] | None = None,
        render_width: int = DEFAULT_RENDER_WIDTH,
        render_height: int = DEFAULT_RENDER_HEIGHT,
        plugins: PluginHost | None = None,
    ) -> None:
        if (model_path is None) == (xml is None):
            raise TypeError("MuJoCoEngine needs exactly one of model_path= or xml=")
        path = resolve_data_path(model_path) if model_path is not None else None
        if plugins is None and path is not None and path.suffix.lower() not in MJCF_SUFFIXES:
            plugins = PluginHost.discover()  # the documented API: a USD file given without a host reads as in a run
        self.model = compile_model(path, xml=xml, assets=assets, plugins=plugins)
        self.data = mujoco.MjData(self.model)
        self.render_width = render_width
        self.render_height = render_height
        self._renderer: mujoco.Renderer | None = None
        self._sensor_slices = {
            self.model.sensor(i).name: slice(
                self.model.sensor_adr[i], self.model.sensor_adr[i] + self.model.sensor_dim[i]
            )
            for i in range(self.model.nsensor)
        }
        mujoco.mj_forward(self.model, self.data)

    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    @property
    def time(self) -> float:
        return float(self.data.time)

    def reset(self, keyframe: str | None = None) -> None:
        """mj_resetData, or mj_resetDataKeyframe for a named keyframe; then recompute derived quantities."""
        if keyframe is None:
            mujoco.mj_resetData(self.model, self.data)
        else:
            key_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_KEY, keyframe)
            if key_id < 0:
                names = [self.model.key(i).name for i in range(self.model.nkey)]
                raise KeyError(f"no keyframe '{keyframe}' in the model; keyframes: {', '.join(names) or 'none'}")
            mujoco.mj_resetDataKeyframe(self.model, self.data, key_id)
        mujoco.mj_forward(self.model, self.data)

    def step(self, n: int = 1) -> None:
        """mj_step `n` times; a negative `n` is a ValueError (mj_step would silently do nothing)."""
        if n < 0:
            raise ValueError(f"step expects a number of steps >= 0, got {n}")
        mujoco.mj_step(self.model, self.data, n)

    def set_ctrl(self, values: ArrayLike) -> None:
        """Set `data.ctrl`; applied at the next step. Checked first, so a bad call changes nothing."""
        if np.iscomplexobj(values):  # float64 conversion would drop the imaginary part with only a warning
            raise ValueError("set_ctrl expects real numbers, got complex values")
        ctrl = np.asarray(values, dtype=np.float64)
        if ctrl.shape != (self.model.nu,):
            raise ValueError(f"set_ctrl expects {self.model.nu} values (one per actuator), got shape {ctrl.shape}")
        bad = np.flatnonzero(~np.isfinite(ctrl))
        if bad.size:
            names = ", ".join(f"{self.model.actuator(i).name or i}={ctrl[i]}" for i in bad)
            raise ValueError(f"set_ctrl got non-finite values for actuators: {names}")
        self.data.ctrl[:] = ctrl

    def get_qpos(self) -> NDArray[np.float64]:
        return self.data.qpos.copy()

    def get_sensor(self, name: str) -> NDArray[np.float64]:
        try:
            return self.data.sensordata[self._sensor_slices[name]].copy()
        except KeyError:
            raise KeyError(
                f"no sensor '{name}' in the model; sensors: {', '.join(self._sensor_slices) or 'none'}"
            ) from None

    def instability(self) -> str | None:
        """MuJoCo's bad-qacc/qvel/qpos/ctrl warnings since the last reset, as one message."""
        raised = [
            f"{warning.name} x{self.data.warning[warning].number}"
            for warning in _INSTABILITY_WARNINGS
            if self.data.warning[warning].number
        ]
        return f"MuJoCo reported a non-finite state ({', '.join(raised)})" if raised else None

    def render(self, camera: str | int | None = None) -> NDArray[np.uint8]:
        """(H, W, 3) uint8 image of the current state from `camera` (default: the model's first camera,
        else the free camera)."""
        if camera is None:
            camera = camera_id(self.model, None)
        renderer = self._renderer or self._create_renderer()
        renderer.update_scene(self.data, camera=camera)
        return renderer.render()

    def _create_renderer(self) -> mujoco.Renderer:
        self._renderer = create_renderer(self.model, self.render_width, self.render_height)
        return self._renderer

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


class MuJoCoBackend(Backend):
    """The `mujoco` backend: a MuJoCoEngine per model, and `BatchedVectorEnv`s (EnvKind.NUMPY) for training."""

    def create_engine(
        self,
        model_path: Path,
        plugins: PluginHost,
        *,
        render_width: int = DEFAULT_RENDER_WIDTH,
        render_height: int = DEFAULT_RENDER_HEIGHT,
    ) -> MuJoCoEngine:
        return MuJoCoEngine(model_path, render_width=render_width, render_height=render_height, plugins=plugins)

    def create_envs(self, spec: EnvSpec, kind: EnvKind, plugins: PluginHost) -> BatchedVectorEnv:
        if kind is not EnvKind.NUMPY:
            raise ConfigError(f"backend mujoco provides NUMPY environments, not {kind.name}")
        from joshua_mujoco.vector import vector_envs

        return vector_envs(spec, plugins)
