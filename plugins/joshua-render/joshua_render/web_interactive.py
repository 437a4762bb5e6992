"""The browser page of a live simulation: the desktop viewer's controls that a viser page can offer.

Besides pause and step (`WebDisplay`): reset to the start state, the speed (real-time factor), contact
points, contact forces and body frames drawn with viser's scene primitives, and dragging a body: a body
chosen in the panel gets a transform gizmo at its centre of mass, and while it is chosen a spring pulls it
towards the gizmo, the force MuJoCo's viewers apply for a ctrl+drag (`mjv_applyPerturbForce` into
`xfrc_applied`, recomputed at each `update` from the current state, as the viewer's sync does). Releasing
it (choosing "-", or Reset) removes the force. The loop that steps the physics stays the caller's: the page
only records what the browsers ask for (`InteractiveControls`) and writes the perturbation in `update`.
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING

import numpy as np

from joshua_render.web import NO_MARK, WebControls, WebDisplay, start_server

if TYPE_CHECKING:
    import mujoco
    import viser

SPEEDS = (0.05, 2.0)  # the speed slider's range, in simulated seconds per wall-clock second
DRAG_REACH_EXTENTS = 10.0  # a drag target stays within this many model extents of the model's centre, per axis
CONTACT_POINT_SCALE = 0.5  # a contact point's sphere radius, in MuJoCo's contact width (vis.scale.contactwidth)


class InteractiveControls(WebControls):
    """Pause, step, reset and speed asked for in any browser (set on viser's threads, read by the loop)."""

    def __init__(self) -> None:
        super().__init__()
        self.speed = 1.0  # simulated seconds per wall-clock second
        self._reset = False

    def reset(self) -> None:
        with self._lock:
            self._reset = True

    def take_reset(self) -> bool:
        """Whether a browser asked to go back to the start state since the last call."""
        with self._lock:
            reset, self._reset = self._reset, False
            return reset


class _Drag:
    """The dragged body and its gizmo's pose, as the browsers set them (on viser's threads)."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.body: int | None = None
        self.target: tuple[np.ndarray, np.ndarray] | None = None  # (position, wxyz); None: not placed yet


class InteractivePage(WebDisplay):
    """A live simulation in the browser with the desktop viewer's controls a page can offer (module docstring)."""

    def __init__(self, server: viser.ViserServer, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        import mujoco

        super().__init__(server, model, data)
        self.controls: InteractiveControls = InteractiveControls()
        gui, scene, allow = server.gui, server.scene, self._inputs.allow
        allow(gui.add_button("Reset")).on_click(self._on_reset)
        speed = allow(gui.add_slider("speed (x real time)", min=SPEEDS[0], max=SPEEDS[1], step=0.05, initial_value=1.0))
        speed.on_update(lambda _: setattr(self.controls, "speed", float(speed.value)))

        size = float(model.stat.meansize)
        self._show_contacts = allow(gui.add_checkbox("contact points", initial_value=False))
        self._show_forces = allow(gui.add_checkbox("contact forces", initial_value=False))
        show_frames = allow(gui.add_checkbox("body frames", initial_value=False))
        self._axes = [  # children of the drawn bodies' frames: they move with them
            scene.add_frame(
                f"{frame.name}/axes",
                axes_length=model.vis.scale.framelength * size,
                axes_radius=model.vis.scale.framewidth * size,
                origin_radius=0.0,
                visible=False,
            )
            for frame in self._scene.body_frames.values()
        ]
        show_frames.on_update(lambda _: [setattr(axes, "visible", show_frames.value) for axes in self._axes])
        sphere = _unit_sphere()
        self._contact_points = scene.add_batched_meshes_simple(
            "/contacts/points",
            vertices=sphere[0] * CONTACT_POINT_SCALE * model.vis.scale.contactwidth * size,
            faces=sphere[1],
            batched_wxyzs=np.array([[1.0, 0.0, 0.0, 0.0]]),
            batched_positions=np.zeros((1, 3)),
            batched_colors=tuple(int(255 * c) for c in model.vis.rgba.contactpoint[:3]),
            visible=False,
        )
        self._contact_forces = scene.add_line_segments(
            "/contacts/forces",
            points=np.zeros((1, 2, 3), np.float32),
            colors=tuple(int(255 * c) for c in model.vis.rgba.contactforce[:3]),
            line_width=3.0,
            visible=False,
        )

        self._drag = _Drag()
        self._dragged: int | None = None  # the body whose xfrc_applied the page wrote last
        self._perturb = mujoco.MjvPerturb()
        self._start_wxyz = np.array([1.0, 0.0, 0.0, 0.0])  # the gizmo's orientation when placed: no turn asked
        self._camera_scene = mujoco.MjvScene(model, maxgeom=model.ngeom)  # for mjv_initPerturb's camera only
        draggable = {
            int(body): model.body(int(body)).name or f"body {body}"
            for body in self._scene.body_frames
            if model.body_weldid[body] != 0  # a body welded to the world does not move
        }
        self._draggable = {name: body for body, name in draggable.items()}
        self._drag_body = allow(
            gui.add_dropdown("drag body", options=(NO_MARK, *self._draggable), initial_value=NO_MARK)
        )
        self._drag_body.on_update(self._on_drag_body)
        reach = DRAG_REACH_EXTENTS * float(model.stat.extent)
        low, high = tuple(np.asarray(model.stat.center) - reach), tuple(np.asarray(model.stat.center) + reach)
        self._drag_target = allow(
            gui.add_vector3(
                "drag target (m)", initial_value=(0.0, 0.0, 0.0), min=low, max=high, step=0.01, visible=False
            )
        )
        self._drag_target.on_update(self._on_target_typed)
        self._gizmo = scene.add_transform_controls(
            "/drag", scale=float(model.stat.extent) / 4, depth_test=False, visible=False
        )
        self._inputs.allow_gizmo(self._gizmo, "drag gizmo", low, high)
        self._gizmo.on_update(self._on_gizmo)

    # --- viser's threads: record what a browser asked for -------------------------------------------------

    def _on_reset(self, _: object) -> None:
        self._release()
        self.controls.reset()

    def _release(self) -> None:
        with self._drag.lock:
            self._drag.body, self._drag.target = None, None
        self._drag_body.value = NO_MARK
        self._drag_target.visible = self._gizmo.visible = False

    def _on_drag_body(self, event: viser.GuiEvent) -> None:
        if event.client is None:  # the page set it (a release)
            return
        body = self._draggable.get(self._drag_body.value)
        if body is None:
            self._release()
            return
        with self._drag.lock:  # `update` places the gizmo on the body, from the loop's thread
            self._drag.body, self._drag.target = body, None

    def _on_gizmo(self, _: object) -> None:
        position = np.array(self._gizmo.position, np.float64)
        with self._drag.lock:
            if self._drag.body is not None:
                self._drag.target = (position, np.array(self._gizmo.wxyz, np.float64))
        self._drag_target.value = tuple(round(float(p), 4) for p in position)

    def _on_target_typed(self, event: viser.GuiEvent) -> None:
        if event.client is None:  # the page set it from the gizmo
            return
        position = np.array(self._drag_target.value, np.float64)
        with self._drag.lock:
            if self._drag.body is None or self._drag.target is None:
                return
            self._drag.target = (position, self._drag.target[1])
        self._gizmo.position = position

    # --- the loop's thread --------------------------------------------------------------------------------

    def update(self, time: float) -> bool:
        self._apply_drag()
        pushed = self._last_push
        shown = super().update(time)
        if self._last_push != pushed:  # the poses went out: the contacts go with them
            self._push_contacts()
        return shown

    def _apply_drag(self) -> None:
        """Write the spring force towards the gizmo into `xfrc_applied`, as the desktop viewer does before each
        sync; clear the force of a body no longer dragged."""
        import mujoco

        model, data, perturb = self._model, self._data, self._perturb
        with self._drag.lock:
            body, target = self._drag.body, self._drag.target
            if body is not None and target is None:  # just chosen: the gizmo starts at its centre of mass
                target = self._drag.target = (data.xipos[body].copy(), data.xquat[body].copy())
                placed = True
            else:
                placed = False
        if self._dragged is not None:
            data.xfrc_applied[self._dragged] = 0.0
        self._dragged = body
        if body is None or target is None:
            perturb.active = 0
            return
        if placed:
            perturb.select = body
            perturb.localpos = data.xmat[body].reshape(3, 3).T @ (data.xipos[body] - data.xpos[body])
            mujoco.mjv_updateScene(
                model, data, mujoco.MjvOption(), mujoco.MjvPerturb(), mujoco.MjvCamera(), 0, self._camera_scene
            )  # mjv_initPerturb reads the scene's camera for its pixel scale; the force does not use it
            mujoco.mjv_initPerturb(model, data, self._camera_scene, perturb)  # localmass, as the viewer sets it
            self._start_wxyz = target[1]
            with self._server.atomic():
                self._gizmo.position, self._gizmo.wxyz = target
                self._gizmo.visible = True
                self._drag_target.value = tuple(round(float(p), 4) for p in target[0])
                self._drag_target.visible = True
        position, wxyz = target
        rotated = abs(abs(float(np.dot(wxyz, self._start_wxyz))) - 1.0) > 1e-9
        perturb.active = mujoco.mjtPertBit.mjPERT_TRANSLATE | (mujoco.mjtPertBit.mjPERT_ROTATE if rotated else 0)
        perturb.refselpos = position
        mujoco.mju_mulQuat(perturb.refquat, wxyz, model.body_iquat[body])  # mjPERT_ROTATE turns the inertia frame
        mujoco.mjv_applyPerturbForce(model, data, perturb)

    def _push_contacts(self) -> None:
        points, forces = self._show_contacts.value, self._show_forces.value
        count = self._data.ncon if points or forces else 0
        with self._server.atomic():
            self._contact_points.visible = points and count > 0
            self._contact_forces.visible = forces and count > 0
            if count == 0:
                return
            contacts = self._data.contact
            positions = np.array(contacts.pos[:count], np.float32)
            if points:
                self._contact_points.batched_positions = positions
                self._contact_points.batched_wxyzs = np.tile(np.array([1.0, 0.0, 0.0, 0.0], np.float32), (count, 1))
            if forces:
                self._contact_forces.points = np.stack([positions, positions + self._force_vectors(count)], axis=1)

    def _force_vectors(self, count: int) -> np.ndarray:
        """Each contact's force in world coordinates, scaled to lengths as MuJoCo's viewers draw them."""
        import mujoco

        model, data = self._model, self._data
        local = np.zeros(6)
        vectors = np.zeros((count, 3), np.float32)
        for i in range(count):
            mujoco.mj_contactForce(model, data, i, local)
            vectors[i] = data.contact.frame[i].reshape(3, 3).T @ local[:3]  # the frame's rows are its axes
        return vectors * (model.vis.map.force / model.stat.meanmass)


def _unit_sphere() -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
    return np.asarray(sphere.vertices, np.float32), np.asarray(sphere.faces, np.uint32)


def open_interactive_page(model: mujoco.MjModel, data: mujoco.MjData, address: str, *, title: str) -> InteractivePage:
    """An InteractivePage on `address`; an address it cannot listen on is a UsageError (a live simulation nobody
    can watch is no use)."""
    server = start_server(address, title=title, instead=None)
    assert server is not None  # instead=None raises rather than returning None
    return InteractivePage(server, model, data)
