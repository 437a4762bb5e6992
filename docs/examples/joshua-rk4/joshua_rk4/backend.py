"""The `mujoco_rk4` backend: a `MuJoCoEngine` whose model steps with the 4th-order Runge-Kutta integrator.

Imported only when a run uses the backend, so importing mujoco here is fine.
"""

from __future__ import annotations

from pathlib import Path

import mujoco

from joshua_core.interfaces import DEFAULT_RENDER_HEIGHT, DEFAULT_RENDER_WIDTH, Backend
from joshua_core.plugins import PluginHost
from joshua_mujoco import MuJoCoEngine


class RK4Backend(Backend):
    """Creates MuJoCo engines that integrate with RK4 instead of the integrator the model file names."""

    def create_engine(
        self,
        model_path: Path,
        plugins: PluginHost,
        *,
        render_width: int = DEFAULT_RENDER_WIDTH,
        render_height: int = DEFAULT_RENDER_HEIGHT,
    ) -> MuJoCoEngine:
        engine = MuJoCoEngine(model_path, render_width=render_width, render_height=render_height, plugins=plugins)
        engine.model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
        return engine
