"""The live MuJoCo viewer of a PPO run: a few training environments, shown after every iteration."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from joshua_core.config_pb2 import PpoOptions
from joshua_core.errors import UsageError

DEFAULT_VIEWER_ENVS = 4


class LiveViewer:
    """The MuJoCo viewer showing a few training environments, updated after every iteration: the first one
    as the scene, the others drawn into it (on top of each other, where they all start from one place)."""

    def __init__(self, model_path: Path, envs: int) -> None:
        from joshua_modes.display import ViewerDisplay
        from joshua_mujoco import MuJoCoEngine

        self.engine = MuJoCoEngine(model_path)
        self.display = ViewerDisplay(self.engine)
        self.envs = envs
        self._ghost = mujoco.MjData(self.engine.model)
        self._option = mujoco.MjvOption()
        self._perturb = mujoco.MjvPerturb()

    def show(self, qpos: np.ndarray, status: str) -> bool:
        """Show the poses (envs, nq); False once the user closed the window."""
        model = self.engine.model
        with self.display.lock():
            self.engine.data.qpos[:] = qpos[0]
            mujoco.mj_forward(model, self.engine.data)
            scene = self.display.user_scene
            scene.ngeom = 0
            for pose in qpos[1:]:
                self._ghost.qpos[:] = pose
                mujoco.mj_kinematics(model, self._ghost)
                mujoco.mjv_addGeoms(
                    model, self._ghost, self._option, self._perturb, mujoco.mjtCatBit.mjCAT_DYNAMIC, scene
                )
        self.display.set_status(status)
        return self.display.update(self.engine.time)

    def close(self) -> None:
        self.display.close()
        self.engine.close()


def open_viewer(options: PpoOptions, model_path: Path) -> LiveViewer | None:
    """The live viewer the options ask for: AUTO opens it when joshua-modes is installed and a display is usable."""
    if options.viewer == PpoOptions.OFF:
        return None
    try:
        from joshua_modes.display import display_usable, no_display_error
    except ModuleNotFoundError:
        if options.viewer == PpoOptions.ON:
            raise UsageError(
                "training.ppo.viewer ON needs joshua-modes (pip install -e plugins/joshua-modes)"
            ) from None
        return None
    if not display_usable():
        if options.viewer == PpoOptions.ON:
            raise no_display_error("training.ppo.viewer ON (the live MuJoCo viewer)")
        return None
    return LiveViewer(model_path, options.viewer_envs or DEFAULT_VIEWER_ENVS)
