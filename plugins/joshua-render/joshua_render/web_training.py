"""A running training in the browser: a few of its environments side by side, moved by the current policy, the
return curve (viser's uPlot) and how many episodes blew up, for a trainer on a machine with no display.

The trainer only publishes: `publish_poses` and `publish_return` copy a few numbers under a lock and return. A thread
of the page's own turns the newest poses into body poses and sends them at most `TrainingPage.PUSH_HZ` times a second,
and only while a browser is connected; poses published in between are dropped, never queued, so a slow page (or
browser) never slows or stops the training.
"""

from __future__ import annotations

import copy
import threading
from typing import TYPE_CHECKING

import numpy as np

from joshua_render.web import CAMERA_DIRECTION, ClientValues, ModelScene, start_server

if TYPE_CHECKING:
    import mujoco
    import viser

SPACING_EXTENTS = 1.2  # environments stand this many model extents apart, along x
CAMERA_EXTENTS = 0.6  # the first view stands this many extents further back than half the row's length
RETURN_COLOUR = "rgb(220, 20, 60)"  # the return curve's stroke (crimson: apart from the panel's greys and blues)


class TrainingPage:
    """`envs` copies of `model` side by side, the policy's step count, the mean episode return per update and the
    run's count of episodes whose simulation blew up (a run that learns from blow-ups should be seen to)."""

    # Poses sent at most this often (publishing more often only replaces the pending ones). Below the replays' rate:
    # the policy changes once per update, and each pose sent costs the training's process its kinematics and viser's
    # messages, and every watching browser a frame drawn (on a server's CPU in software WebGL, with no GPU).
    PUSH_HZ = 10.0

    def __init__(self, server: viser.ViserServer, model: mujoco.MjModel, envs: int) -> None:
        import mujoco
        from viser import uplot

        self._server = server
        self._inputs = ClientValues(server)  # allows nothing: a browser sets no value on this page
        self._model = copy.deepcopy(model)  # the page's thread must not share a model the trainer may change
        self._data = mujoco.MjData(self._model)
        extent = float(self._model.stat.extent)
        spacing = SPACING_EXTENTS * extent
        self._scenes = [
            ModelScene(server, self._model, f"env{i}", offset=(i * spacing, 0.0, 0.0), planes=i == 0)
            for i in range(envs)
        ]
        middle = np.asarray(self._model.stat.center) + ((envs - 1) * spacing / 2, 0.0, 0.0)
        server.initial_camera.look_at = tuple(middle)
        server.initial_camera.position = tuple(
            middle + (extent + (envs - 1) * spacing / 2) * np.array(CAMERA_DIRECTION)
        )
        gui = server.gui
        self._policy = gui.add_text("policy after (steps)", initial_value="0", disabled=True)
        self._points = gui.add_text("return points", initial_value="0", disabled=True)
        self._blown_up = gui.add_text("episodes blown up", initial_value="0", disabled=True)
        self._curve = gui.add_uplot(
            data=(np.zeros(0), np.zeros(0)),
            series=(uplot.Series(label="steps"), uplot.Series(label="mean return", stroke=RETURN_COLOUR, width=2)),
            title="mean episode return",
            scales={"x": uplot.Scale(time=False)},  # steps, not a date
            aspect=1.5,
        )
        self._lock = threading.Lock()
        self._poses: np.ndarray | None = None  # the newest published (envs, nq), until the thread takes it
        self._policy_step = 0
        self._steps: list[float] = []
        self._returns: list[float] = []
        self._curve_length = 0
        self._failed = 0  # episodes that blew up, over every published update
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="joshua-training-page", daemon=True)
        self._thread.start()

    @property
    def envs(self) -> int:
        return len(self._scenes)

    def publish_poses(self, qpos: np.ndarray, policy_step: int) -> None:
        """The environments' joint positions (envs, nq) now, under the policy updated at `policy_step` (copied)."""
        poses = np.array(qpos[: self.envs], dtype=np.float64)
        with self._lock:
            self._poses, self._policy_step = poses, policy_step

    def publish_return(self, step: int, mean_return: float, failed_episodes: int = 0) -> None:
        """One point of the return curve: the mean return of the episodes finished by `step`, of which
        `failed_episodes` ended because their simulation blew up (added to the page's count)."""
        with self._lock:
            self._steps.append(float(step))
            self._returns.append(float(mean_return))
            self._failed += int(failed_episodes)

    def _run(self) -> None:
        while not self._stop.wait(1.0 / self.PUSH_HZ):
            if not self._server.get_clients():
                continue  # nobody watching: what was published waits, replaced as it comes, for the first browser
            with self._lock:
                poses, self._poses = self._poses, None
                policy_step = self._policy_step
                curve = None
                if len(self._steps) != self._curve_length:
                    curve = (np.array(self._steps), np.array(self._returns))
                failed = self._failed
            if poses is not None:
                self._show(poses, policy_step)
            if curve is not None:
                self._curve.data = curve
                self._points.value = str(len(curve[0]))
                self._curve_length = len(curve[0])
                self._blown_up.value = str(failed)

    def _show(self, poses: np.ndarray, policy_step: int) -> None:
        import mujoco

        with self._server.atomic():
            for scene, qpos in zip(self._scenes, poses, strict=False):
                self._data.qpos[:] = qpos
                mujoco.mj_kinematics(self._model, self._data)
                scene.show(self._data.xpos, self._data.xquat)
            self._policy.value = str(policy_step)

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self._server.stop()


def open_training_page(model: mujoco.MjModel, envs: int, address: str, *, title: str) -> TrainingPage | None:
    """A TrainingPage on `address`; when it cannot listen there, None and one line saying that training goes on
    without it (see `start_server`)."""
    server = start_server(address, title=title, instead="training without it")
    return None if server is None else TrainingPage(server, model, envs)
