"""Show a running simulation: the MuJoCo viewer when a display is usable, else a headless MP4 recording.

`open_display` is shared by the mode plugins (passive replay, the mirror): they change the engine's
state and call `Display.update(time)`; the display either syncs the viewer window or keeps one
frame per 1/fps of `time` in a video. Any `Engine` whose `model` and `data` are MuJoCo's works.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
import signal
import threading
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING

from joshua_core.errors import UsageError
from joshua_core.interfaces import Engine
from joshua_render.frames import camera_id
from joshua_render.gl import has_display
from joshua_render.video import VideoWriter

if TYPE_CHECKING:
    import mujoco

VIEWER_JOIN_TIMEOUT_S = 10.0


class Display(ABC):
    """Where a simulation is shown. A context manager; leaving the block calls `close()`."""

    description: str

    @abstractmethod
    def update(self, time: float) -> bool:
        """Show the engine's current state. `time` (seconds) decides which frames a recording keeps.

        Returns False once the user closed the viewer window (always True when recording).
        """

    @abstractmethod
    def close(self) -> Path | None:
        """Close the window or finish the video; returns the video written when recording, else None."""

    def __enter__(self) -> Display:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, traceback: TracebackType | None
    ) -> None:
        self.close()


def display_usable() -> bool:
    """True if a Wayland display is named, or the X11 display in DISPLAY accepts a connection."""
    if os.environ.get("WAYLAND_DISPLAY"):
        return True
    if not has_display():
        return False
    name = ctypes.util.find_library("X11")
    if name is None:
        return False
    xlib = ctypes.CDLL(name)
    xlib.XOpenDisplay.restype = ctypes.c_void_p
    xlib.XOpenDisplay.argtypes = [ctypes.c_char_p]
    xlib.XCloseDisplay.argtypes = [ctypes.c_void_p]
    connection = xlib.XOpenDisplay(None)
    if not connection:
        return False
    xlib.XCloseDisplay(connection)
    return True


def no_display_error(what: str) -> UsageError:
    """The error for asking for a window where there is no usable display; it says what to do instead."""
    shown = os.environ.get("DISPLAY")
    reason = f"cannot connect to display '{shown}'" if shown else "DISPLAY is not set"
    return UsageError(
        f"{what} needs a display, but {reason}. Render without one with the sim_offscreen preset "
        "(joshua --preset sim_offscreen), start a virtual display (Xvfb :99 & then DISPLAY=:99 joshua ...), "
        "or set DISPLAY to a running X server"
    )


def open_display(
    engine: Engine,
    *,
    output_dir: Path,
    name: str,
    fps: float = 30.0,
    camera: str | None = None,
    viewer: bool | None = None,
) -> Display:
    """The viewer (`viewer=True`, or None with a usable display), else a recording to `output_dir/NAME.mp4`.

    `viewer=True` with no usable display raises UsageError suggesting sim_offscreen, Xvfb or DISPLAY.
    """
    window = display_usable() if viewer is None else viewer
    if window:
        if viewer and not display_usable():
            raise no_display_error("the MuJoCo viewer")
        return ViewerDisplay(engine.model, engine.data, camera=camera)
    return RecordingDisplay(engine, Path(output_dir) / f"{name}.mp4", fps=fps, camera=camera)


class ViewerDisplay(Display):
    """The MuJoCo viewer (`mujoco.viewer.launch_passive`) showing `data` of `model` (an engine's, or one's own).

    The viewer renders on its own thread; `close()` closes the window and joins that thread, so
    nothing is left running at interpreter exit. `key_callback` gets the GLFW key code of each key press.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        *,
        camera: str | None = None,
        key_callback: Callable[[int], None] | None = None,
    ) -> None:
        if not display_usable():
            raise no_display_error("the MuJoCo viewer")
        import mujoco.viewer  # here, not at the top: it loads GLFW, which recording does not need

        fixed_camera = camera_id(model, camera) if camera else None
        before = set(threading.enumerate())
        self._handle = mujoco.viewer.launch_passive(model, data, key_callback=key_callback)
        self._threads = [thread for thread in threading.enumerate() if thread not in before]
        if fixed_camera is not None:
            with self._handle.lock():
                self._handle.cam.type = mujoco.mjtCamera.mjCAMERA_FIXED
                self._handle.cam.fixedcamid = fixed_camera
        self.description = "MuJoCo viewer"

    @contextlib.contextmanager
    def lock(self) -> Iterator[None]:
        """Hold the viewer's lock (while changing the state from another thread than the caller's loop)."""
        with self._handle.lock():
            yield

    @property
    def user_scene(self) -> mujoco.MjvScene:
        """The viewer's extra scene: geoms added here (under `lock()`) are drawn with the model's."""
        return self._handle.user_scn

    def update(self, time: float) -> bool:
        if not self._handle.is_running():
            return False
        self._handle.sync()
        return True

    def set_status(self, text: str) -> None:
        """Show one line of text in the window's top-left corner (empty: none)."""
        if text:
            self._handle.set_texts((None, None, text, ""))
        else:
            self._handle.clear_texts()

    def close(self) -> Path | None:
        with _sigint_ignored():  # a second Ctrl-C must not cut the join short (GLFW would be torn down mid-frame)
            self._handle.close()
            for thread in self._threads:
                thread.join(VIEWER_JOIN_TIMEOUT_S)
        return None


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """Ignore SIGINT inside the block (on the main thread; elsewhere signals cannot be handled anyway)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


class RecordingDisplay(Display):
    """Records the engine's state to an MP4, one frame per 1/fps of the `time` given to `update`."""

    def __init__(self, engine: Engine, path: Path, *, fps: float = 30.0, camera: str | None = None) -> None:
        self._engine = engine
        self._camera = camera_id(engine.model, camera)
        self._video = VideoWriter(path, fps)
        self._interval = 1.0 / fps
        self._next_time: float | None = None
        self.description = f"recording to {path}"

    def update(self, time: float) -> bool:
        if self._next_time is None or time < self._next_time - self._interval:  # first frame, or time went back
            self._next_time = time
        slack = 1e-6 * self._interval  # times computed as start + k/fps land a rounding error short
        if time >= self._next_time - slack:
            frame = self._engine.render(self._camera)
            while time >= self._next_time - slack:  # one frame per interval passed keeps the video's timing
                self._video.write(frame)
                self._next_time += self._interval
        return True

    @property
    def frames(self) -> int:
        return self._video.frames

    def close(self) -> Path | None:
        if self._video.frames == 0:
            return None
        return self._video.close()
