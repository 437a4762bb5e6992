"""The live training viewer: a few training environments' poses in the MuJoCo viewer, updated by a trainer."""

from __future__ import annotations

import copy

from joshua_render.gl import choose_headless_gl

choose_headless_gl()  # must run before mujoco is imported: mujoco picks its GL platform at import

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from joshua_render.display import ViewerDisplay, display_usable, no_display_error  # noqa: E402


class LiveViewer:
    """The MuJoCo viewer showing a few training environments, updated after every iteration: the first one
    as the scene, the others drawn into it (on top of each other, where they all start from one place)."""

    def __init__(self, model: mujoco.MjModel, envs: int) -> None:
        self.model = copy.deepcopy(model)  # the viewer's controls may change its model; the trainer's stays as is
        self.data = mujoco.MjData(self.model)
        self.display = ViewerDisplay(self.model, self.data)
        self.envs = envs
        self._ghost = mujoco.MjData(self.model)
        self._option = mujoco.MjvOption()
        self._perturb = mujoco.MjvPerturb()

    def show(self, qpos: np.ndarray, status: str) -> bool:
        """Show the poses (envs, nq); False once the user closed the window."""
        model = self.model
        with self.display.lock():
            self.data.qpos[:] = qpos[0]
            mujoco.mj_forward(model, self.data)
            scene = self.display.user_scene
            scene.ngeom = 0
            for pose in qpos[1:]:
                self._ghost.qpos[:] = pose
                mujoco.mj_kinematics(model, self._ghost)
                mujoco.mjv_addGeoms(
                    model, self._ghost, self._option, self._perturb, mujoco.mjtCatBit.mjCAT_DYNAMIC, scene
                )
        self.display.set_status(status)
        return self.display.update(float(self.data.time))

    def close(self) -> None:
        self.display.close()


def open_viewer(model: mujoco.MjModel, envs: int, *, required: bool, what: str) -> LiveViewer | None:
    """A LiveViewer of `envs` environments when a display is usable; else None, or, when `required`, the
    UsageError saying that `what` (e.g. "training.ppo.viewer ON") needs a display and what to do instead."""
    if display_usable():
        return LiveViewer(model, envs)
    if required:
        raise no_display_error(what)
    return None
