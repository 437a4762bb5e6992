"""The browser display: a running simulation shown in a web page, for machines with no X display.

The page is served by viser (docs/web-display.md says why viser and not MuJoCo Studio's web viewer):
the browser draws the model's visible geoms with three.js; the simulation only sends each body's
pose, at most `PUSH_HZ` times per second, and viser keeps only the newest value of each pose for a
client that falls behind, so a slow or closed browser never holds the simulation back. Any number of
browsers may watch; each sees the same scene and the same controls (pause, step, scrub). What a browser sends
is checked against its control before the run sees it (`ClientValues`): a value a control does not take is one
line on the terminal, and the run goes on.
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import logging
import math
import reprlib
import socket
import sys
import threading
import time as clock
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from joshua_core.errors import UsageError
from joshua_render.display import Display
from joshua_render.web_access import AccessRule, guarded_serve

if TYPE_CHECKING:
    import mujoco
    import viser
    from viser.infra import ClientId
    from viser.infra._infra import Message

DEFAULT_HOST = "127.0.0.1"  # only this machine, unless the address names another interface
DEFAULT_PORT = 8080
PUSH_HZ = 30.0  # body poses sent to the browsers at most this often
VISIBLE_GROUPS = (0, 1, 2)  # the geom groups MuJoCo's viewers show by default
PLANE_HALF_SIZE_M = 5.0  # an infinite plane (size 0) is drawn this large
CAMERA_DIRECTION = (0.8, -1.1, 0.7)  # where the first view looks from, in model extents from the model's centre
NO_MARK = "-"  # the "go to" list's entry that goes nowhere
UNIT_TOLERANCE = 1e-3  # how far from 1 the norm of a gizmo's orientation sent by a browser may be (its rounding: 1e-7)
INSTALL_HINT = "the web display needs viser: pip install 'joshua-render[web]'"


def parse_web_address(text: str) -> tuple[str, int]:
    """`[HOST:]PORT` (an IPv6 host in brackets) as (host, port); empty means 127.0.0.1:8080."""
    text = text.strip()
    if not text:
        return DEFAULT_HOST, DEFAULT_PORT
    host, separator, port_text = text.rpartition(":")
    if not separator:
        host, port_text = DEFAULT_HOST, text
    host = host.strip("[]") or DEFAULT_HOST
    try:
        port = int(port_text)
    except ValueError:
        raise UsageError(f"web address '{text}': expected [HOST:]PORT, e.g. 8080 or 0.0.0.0:8080") from None
    if not 0 <= port <= 65535:
        raise UsageError(f"web address '{text}': port {port} is not between 0 and 65535")
    return host, port


def _bind_problem(host: str, port: int) -> str | None:
    """Why `host:port` cannot be listened on, or None if it can (checked by binding it once).

    viser itself moves on to the next port when one is taken, and never returns when the address
    cannot be bound at all; checking first keeps the address the user asked for, or says why not.
    """
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except socket.gaierror as error:
        return f"unknown host '{host}' ({error.strerror})"
    family, kind, proto, _, address = infos[0]
    with socket.socket(family, kind, proto) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server's own socket does
        try:
            probe.bind(address)
        except OSError as error:
            if error.errno == errno.EADDRINUSE:
                return f"port {port} is in use"
            if error.errno == errno.EADDRNOTAVAIL:
                return f"{host} is not an address of this machine"
            return error.strerror or str(error)
    return None


def start_server(address: str, *, title: str, instead: str | None) -> viser.ViserServer | None:
    """A viser server on `address` ([HOST:]PORT), its URL printed. When the address cannot be listened on:
    None, with one line saying why and what the run does `instead` (e.g. "recording the replay instead"), or,
    with `instead` None (nothing else is worth doing), a UsageError saying why."""
    host, port = parse_web_address(address)
    problem = _bind_problem(host, port)
    if problem is not None:
        where = f"{host}:{port}"
        if instead is None:
            raise UsageError(f"the web display cannot listen on {where}: {problem}")
        print(f"joshua: warning: no web display (cannot listen on {where}: {problem}); {instead}", file=sys.stderr)
        return None
    try:
        import viser
    except ImportError:
        raise UsageError(INSTALL_HINT) from None
    logging.getLogger("websockets.server").addFilter(_CLIENT_ERRORS)  # adding it again changes nothing
    rule = AccessRule(host, port)
    with guarded_serve(rule) as guarded:
        server = viser.ViserServer(host=host, port=port, label=title, verbose=False)
    if not guarded:
        server.stop()
        raise UsageError(f"viser {viser.__version__} starts its server in a way JOSHUA cannot guard; {INSTALL_HINT}")
    rule.port = server.get_port()
    shown = f"[{host}]" if ":" in host else host
    scope = "this machine only" if rule.token is None else "reachable from the network; the token is needed"
    print(f"web display: {rule.page_url(shown)} ({scope})", flush=True)
    return server


class _OneLineClientErrors(logging.Filter):
    """The websockets server under viser logs a client that does not speak HTTP or WebSocket (a port scanner, a
    wrong URL scheme) with a traceback; the run says it in one line and goes on."""

    def filter(self, record: logging.LogRecord) -> bool:
        if not record.exc_info:
            return True
        problem = record.exc_info[1]
        cause = problem.__cause__ if problem is not None and problem.__cause__ is not None else problem
        _warn_off_protocol(cause)
        return False


_CLIENT_ERRORS = _OneLineClientErrors()


def _warn_off_protocol(problem: BaseException | None) -> None:
    """One line for a client's message the page could not take, instead of its traceback."""
    print(f"joshua: warning: web display: a client sent something else than the page's protocol ({problem}); "
          "ignored it", file=sys.stderr, flush=True)  # fmt: skip


Control = TypeVar("Control", bound="viser.GuiInputHandle")
_OTHER = object()  # stands for what a browser sent that was not a value alone (other properties): no control takes it


@dataclasses.dataclass(frozen=True)
class _Gizmo:
    """A transform gizmo browsers may move (`label` names it in the terminal), its position inside the box `low` to
    `high` (m)."""

    handle: viser.TransformControlsHandle
    label: str
    low: tuple[float, ...]
    high: tuple[float, ...]


def _numbers_within(value: object, low: Sequence[float], high: Sequence[float]) -> bool:
    """Whether `value` is a list or tuple of len(low) numbers (not bools), each within its bounds (so finite)."""
    return (
        isinstance(value, list | tuple)
        and len(value) == len(low)
        and all(
            isinstance(x, int | float) and not isinstance(x, bool) and lo <= x <= hi  # NaN fails the comparison
            for x, lo, hi in zip(value, low, high, strict=True)
        )
    )


def _box(low: Sequence[float], high: Sequence[float]) -> str:
    """The box from `low` to `high` as the terminal shows it."""
    return f"from ({', '.join(f'{x:g}' for x in low)}) to ({', '.join(f'{x:g}' for x in high)})"


def _refusal(control: viser.GuiInputHandle | _Gizmo, value: object) -> str | None:
    """None when a browser may set `control` to `value`; else what the control takes. The one check of every value a
    browser sends, against what its control declares: a button a click, a checkbox true or false, a dropdown one of
    its options, a slider or a vector numbers within its bounds, a gizmo a (wxyz, position) pose inside its box."""
    import viser

    if isinstance(control, viser.GuiButtonHandle):
        return None if value is True else "a click: true"
    if isinstance(control, viser.GuiCheckboxHandle):
        return None if isinstance(value, bool) else "true or false"
    if isinstance(control, viser.GuiDropdownHandle):
        return None if isinstance(value, str) and value in control.options else "one of its options"
    if isinstance(control, viser.GuiSliderHandle):
        within = _numbers_within((value,), (control.min,), (control.max,))
        return None if within else f"a number from {control.min:g} to {control.max:g}"
    if isinstance(control, viser.GuiVector3Handle) and control.min is not None and control.max is not None:
        within = _numbers_within(value, control.min, control.max)
        return None if within else f"3 numbers {_box(control.min, control.max)}"
    if isinstance(control, _Gizmo):
        wxyz, position = value if isinstance(value, tuple) else (None, None)
        unit = _numbers_within(wxyz, (-1.0,) * 4, (1.0,) * 4) and abs(math.hypot(*wxyz) - 1.0) <= UNIT_TOLERANCE
        within = _numbers_within(position, control.low, control.high)
        return None if unit and within else f"a unit quaternion and a position {_box(control.low, control.high)}"
    return "nothing: the page does not check this kind of control"


class ClientValues:
    """What browsers may set on a page, checked before viser applies it (viser casts a value to its control's type:
    a string for a number is a traceback, and NaN or 1e300 goes through). Only the controls a page `allow`s take
    values from browsers, only their value (no other property), and only one `_refusal` finds right; a gizmo it
    `allow_gizmo`s takes only poses inside its box. Anything else is ignored: the control is set back to the value
    in force in every browser, the terminal gets one line per control, and the run goes on."""

    def __init__(self, server: viser.ViserServer) -> None:
        self._websock = server._websock_server
        self._controls: dict[str, viser.GuiInputHandle] = {}  # by uuid
        self._gizmos: dict[str, _Gizmo] = {}  # by scene node name
        self._warned: set[int | None] = set()  # the controls (by id) said to have ignored a value; None: any other
        # viser has no hook for a client's messages: the check goes in front of its dispatch of them. viser warns in
        # two lines of a pose of the wrong length, before the check says it in one.
        self._dispatch = self._websock._handle_incoming_message
        self._websock._handle_incoming_message = self._checked  # type: ignore[method-assign]
        warnings.filterwarnings("ignore", message=r"\[viser\] .* does not match annotation")

    def allow(self, control: Control) -> Control:
        """Let browsers set `control`'s value (to one `_refusal` finds right); returns it."""
        self._controls[control._impl.uuid] = control
        return control

    def allow_gizmo(
        self, gizmo: viser.TransformControlsHandle, label: str, low: Sequence[float], high: Sequence[float]
    ) -> None:
        """Let browsers move `gizmo` (named `label` in the terminal) to positions from `low` to `high` (m)."""
        self._gizmos[gizmo.name] = _Gizmo(gizmo, label, tuple(map(float, low)), tuple(map(float, high)))

    async def _checked(self, client_id: ClientId, message: Message) -> None:
        """viser's dispatch of `message` if `_taken`; a client's message that viser then fails to handle (a wrong
        type where nothing is checked) is one line, not a traceback."""
        if not self._taken(message):
            return
        try:
            await self._dispatch(client_id, message)
        except Exception as error:  # a client's message failed, not the run
            _warn_off_protocol(error)

    def _taken(self, message: Message) -> bool:
        """Whether `message` sets nothing browsers may not set, and no control to a value it does not take; if not,
        it is said (once per control) and the browsers get the value in force back."""
        from viser import _messages

        control: viser.GuiInputHandle | _Gizmo | None
        if isinstance(message, _messages.GuiUpdateMessage):
            control = self._controls.get(message.uuid) if isinstance(message.uuid, str) else None
            updates = message.updates
            value = updates["value"] if isinstance(updates, dict) and list(updates) == ["value"] else _OTHER
            shown = updates if value is _OTHER else value
            if control is None:
                self._warn(None, f"ignored {reprlib.repr(shown)} for a control the page alone sets")
                return False
        elif isinstance(message, _messages.TransformControlsUpdateMessage):
            control = self._gizmos.get(message.name) if isinstance(message.name, str) else None
            value = shown = (message.wxyz, message.position)
            if control is None:  # none of this page's: viser finds none either
                return True
        else:
            return True
        expected = _refusal(control, value)
        if expected is None:
            return True
        self._warn(id(control), f"ignored {reprlib.repr(shown)} for '{control.label}' (expected {expected})")
        for in_force in _in_force(control):
            self._websock.queue_message(in_force)
        return False

    def _warn(self, control: int | None, text: str) -> None:
        if control not in self._warned:
            self._warned.add(control)
            print(f"joshua: warning: web display: {text}", file=sys.stderr, flush=True)


def _in_force(control: viser.GuiInputHandle | _Gizmo) -> list[Message]:
    """The messages that show browsers `control`'s value (or pose) in force."""
    from viser import _messages

    if isinstance(control, _Gizmo):
        name = control.handle.name
        return [
            _messages.SetOrientationMessage(name, tuple(control.handle.wxyz.tolist())),
            _messages.SetPositionMessage(name, tuple(control.handle.position.tolist())),
        ]
    return [_messages.GuiUpdateMessage(control._impl.uuid, {"value": control.value})]


def _geom_mesh(model: mujoco.MjModel, geom: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices and faces of one geom in its own frame; None for a type the page does not draw."""
    import mujoco
    import trimesh

    kind, size = model.geom_type[geom], model.geom_size[geom]
    types = mujoco.mjtGeom
    if kind == types.mjGEOM_MESH:
        mesh = model.geom_dataid[geom]
        vertices = model.mesh_vert[model.mesh_vertadr[mesh] : model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]]
        faces = model.mesh_face[model.mesh_faceadr[mesh] : model.mesh_faceadr[mesh] + model.mesh_facenum[mesh]]
        return vertices.astype(np.float32), faces.astype(np.uint32)
    if kind == types.mjGEOM_PLANE:
        half = [s if s > 0 else PLANE_HALF_SIZE_M for s in size[:2]]
        shape = trimesh.creation.box(extents=(2 * half[0], 2 * half[1], 0.002))
        shape.apply_translation((0, 0, -0.001))
    elif kind == types.mjGEOM_BOX:
        shape = trimesh.creation.box(extents=2 * size)
    elif kind == types.mjGEOM_SPHERE:
        shape = trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    elif kind == types.mjGEOM_ELLIPSOID:
        shape = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        shape.apply_scale(size)
    elif kind == types.mjGEOM_CAPSULE:
        shape = trimesh.creation.capsule(height=2 * size[1], radius=size[0], count=(16, 16))
    elif kind == types.mjGEOM_CYLINDER:
        shape = trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=24)
    else:  # heightfields, SDFs: not drawn
        return None
    return np.asarray(shape.vertices, np.float32), np.asarray(shape.faces, np.uint32)


def _geom_rgba(model: mujoco.MjModel, geom: int) -> np.ndarray:
    """The colour MuJoCo draws a geom in: its material's, else its own."""
    material = model.geom_matid[geom]
    return model.mat_rgba[material] if material >= 0 else model.geom_rgba[geom]


class ModelScene:
    """One copy of a model's visible geoms in a viser scene, under `/{name}`, moved by body poses; without its
    `planes` (the floor), so that copies side by side do not draw one floor over another."""

    def __init__(
        self,
        server: viser.ViserServer,
        model: mujoco.MjModel,
        name: str,
        *,
        offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
        planes: bool = True,
    ) -> None:
        import mujoco

        self._offset = np.asarray(offset, np.float64)
        self._frames: dict[int, viser.FrameHandle] = {}
        for geom in range(model.ngeom):
            if model.geom_group[geom] not in VISIBLE_GROUPS or model.geom_rgba[geom][3] == 0:
                continue
            if not planes and model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_PLANE:
                continue
            mesh = _geom_mesh(model, geom)
            if mesh is None:
                continue
            body = int(model.geom_bodyid[geom])
            if body not in self._frames:
                self._frames[body] = server.scene.add_frame(f"/{name}/body{body}", show_axes=False)
            rgba = _geom_rgba(model, geom)
            server.scene.add_mesh_simple(
                f"/{name}/body{body}/geom{geom}",
                vertices=mesh[0],
                faces=mesh[1],
                color=tuple(int(255 * c) for c in rgba[:3]),
                opacity=float(rgba[3]) if rgba[3] < 1 else None,
                position=model.geom_pos[geom],
                wxyz=model.geom_quat[geom],
            )

    @property
    def body_frames(self) -> dict[int, viser.FrameHandle]:
        """The scene frame of each drawn body (by body id): what is added under one moves with that body."""
        return self._frames

    def show(self, xpos: np.ndarray, xquat: np.ndarray) -> None:
        """Move the bodies to world positions `xpos` (nbody, 3) and orientations `xquat` (nbody, 4)."""
        for body, frame in self._frames.items():
            frame.position = xpos[body] + self._offset
            frame.wxyz = xquat[body]


class WebControls:
    """Pause, single steps and scrubbing, asked for in any browser (set on viser's threads, read by the loop)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.paused = False
        self._steps = 0
        self._seek: float | None = None

    def toggle_pause(self) -> None:
        with self._lock:
            self.paused = not self.paused

    def step(self) -> None:
        with self._lock:
            if self.paused:
                self._steps += 1

    def seek(self, time: float) -> None:
        with self._lock:
            self._seek = time

    def take_steps(self) -> int:
        """Single steps asked for since the last call (only while paused)."""
        with self._lock:
            steps, self._steps = self._steps, 0
            return steps

    def take_seek(self) -> float | None:
        """The time a browser scrubbed to since the last call, if any."""
        with self._lock:
            seek, self._seek = self._seek, None
            return seek


class WebDisplay(Display):
    """A simulation in the browser: `data` of `model` drawn by viser, with pause and step (`controls`; not for a
    simulation that follows a robot), for a replay of `duration` seconds a time slider (`marks`, (time, label)
    pairs with labels of their own, marked under it between its ends and listed in a "go to" list that seeks to
    them), and a free text block (`set_report`). `update` never waits for a browser; closing one changes
    nothing."""

    def __init__(
        self,
        server: viser.ViserServer,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        *,
        duration: float | None = None,
        controls: bool = True,
        marks: Sequence[tuple[float, str]] = (),
    ) -> None:
        self._server, self._model, self._data = server, model, data
        self.controls = WebControls()
        self._inputs = ClientValues(server)
        self._scene = ModelScene(server, model, "robot")
        center, extent = np.asarray(model.stat.center), float(model.stat.extent)
        server.initial_camera.look_at = tuple(center)
        server.initial_camera.position = tuple(center + extent * np.array(CAMERA_DIRECTION))
        self._last_push = -np.inf
        gui = server.gui
        if controls:
            self._pause = self._inputs.allow(gui.add_button("Pause"))
            self._pause.on_click(self._on_pause)
            step = self._inputs.allow(gui.add_button("Step"))
            step.on_click(lambda _: self.controls.step())
        self._status = gui.add_text("status", initial_value="running", disabled=True)
        self._time = gui.add_text("time (s)", initial_value="0.000", disabled=True)
        self._slider = None
        if duration is not None and duration > 0:
            self._slider = self._inputs.allow(
                gui.add_slider(
                    "scrub (s)",
                    min=0.0,
                    max=duration,
                    step=duration / 1000,
                    initial_value=0.0,
                    marks=((0.0, "0"), *marks, (duration, f"{duration:.6g}")) if marks else None,
                )
            )
            self._slider.on_update(self._on_scrub)
        self._targets = {f"{label} at {time:.3f} s": time for time, label in marks} if self._slider is not None else {}
        if self._targets:
            self._go_to = self._inputs.allow(
                gui.add_dropdown("go to", options=(NO_MARK, *self._targets), initial_value=NO_MARK)
            )
            self._go_to.on_update(self._on_go_to)
        self._report = gui.add_markdown("", visible=False)
        self.description = f"web display at port {server.get_port()}"
        self._push(0.0)

    def _on_pause(self, _: object) -> None:
        self.controls.toggle_pause()
        paused = self.controls.paused
        self._pause.label = "Resume" if paused else "Pause"
        self._status.value = "paused" if paused else "running"

    def _on_scrub(self, event: viser.GuiEvent) -> None:
        if event.client is not None:  # a browser moved it, not `update`
            self.controls.seek(float(self._slider.value))

    def _on_go_to(self, event: viser.GuiEvent) -> None:
        if event.client is not None and self._go_to.value in self._targets:  # a browser chose a mark
            self.controls.seek(self._targets[self._go_to.value])
            self._go_to.value = NO_MARK  # so that the same mark can be chosen again

    @contextlib.contextmanager
    def lock(self) -> Iterator[None]:
        """Nothing to hold: the page reads the state only inside `update`, on the caller's thread."""
        yield

    def set_status(self, text: str) -> None:
        """One line shown in the panel (empty: running or paused)."""
        self._status.value = text or ("paused" if self.controls.paused else "running")

    def set_report(self, markdown: str) -> None:
        """A block of text (Markdown) under the panel, e.g. a status table; empty hides it."""
        if markdown != self._report.content:
            self._report.content = markdown
            self._report.visible = bool(markdown)

    def _push(self, time: float) -> None:
        with self._server.atomic():
            self._scene.show(self._data.xpos, self._data.xquat)
            self._time.value = f"{time:.3f}"
            if self._slider is not None:
                self._slider.value = min(max(time, self._slider.min), self._slider.max)

    def update(self, time: float) -> bool:
        now = clock.perf_counter()
        if now - self._last_push >= 1.0 / PUSH_HZ:
            self._last_push = now
            self._push(time)
        return True

    def close(self) -> Path | None:
        self._server.stop()
        return None


def open_web_display(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    address: str,
    *,
    title: str,
    instead: str | None,
    duration: float | None = None,
    controls: bool = True,
    marks: Sequence[tuple[float, str]] = (),
) -> WebDisplay | None:
    """A WebDisplay on `address`; when it cannot listen there, None with one line saying why and what the run
    does `instead`, or UsageError when `instead` is None (see `start_server`)."""
    server = start_server(address, title=title, instead=instead)
    if server is None:
        return None
    return WebDisplay(server, model, data, duration=duration, controls=controls, marks=marks)
