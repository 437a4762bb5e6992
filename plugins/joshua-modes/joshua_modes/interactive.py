"""INTERACTIVE mode: the MuJoCo viewer on a live simulation, the robot held at a keyframe by its actuators.

The physics runs in real time on the calling thread; the viewer (mouse drag of bodies, contact and
force visualisation, cameras, rendering options) renders on its own thread. Space pauses and resumes,
Right arrow steps once while paused. Closing the window ends the run; Ctrl-C closes the window, joins
the viewer's thread and re-raises KeyboardInterrupt (the CLI exits with status 130). In a web page
(`InteractivePage`) the same loop also takes the page's Reset (back to the keyframe) and speed.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

from joshua_core.config_pb2 import SimulationConfig
from joshua_core.defaults import DEFAULT_SIMULATION_BACKEND
from joshua_core.errors import ConfigError
from joshua_core.interfaces import Engine, Mode
from joshua_core.plugins import PluginHost
from joshua_core.run_context import RunContext
from joshua_modes.options_pb2 import ViewerOptions
from joshua_render import InteractiveControls, InteractivePage, ViewerDisplay, open_interactive_page

KEY_SPACE = 32  # GLFW key codes, as the viewer's key_callback reports them
KEY_RIGHT = 262
FRAME_PERIOD_S = 1.0 / 60.0
MAX_CATCH_UP_S = 0.1  # after a stall, at most this much simulated time is run at once


class _Controls:
    """Pause and single-step requests from the viewer's key presses (called on the viewer's thread)."""

    speed = 1.0  # real time: the desktop viewer's keys set no other speed for this loop

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.paused = False
        self._steps = 0

    def on_key(self, key: int) -> None:
        with self._lock:
            if key == KEY_SPACE:
                self.paused = not self.paused
            elif key == KEY_RIGHT and self.paused:
                self._steps += 1

    def take_steps(self) -> int:
        with self._lock:
            steps, self._steps = self._steps, 0
            return steps

    def take_reset(self) -> bool:
        """False: going back to the keyframe is the web page's control; no key of the desktop viewer asks it."""
        return False


def run_interactive(
    model_path: str | Path,
    *,
    keyframe: str | None = None,
    duration: float = 0.0,
    plugins: PluginHost | None = None,
    backend: str = DEFAULT_SIMULATION_BACKEND,
) -> None:
    """Open the MuJoCo viewer on `model_path`, held at `keyframe` (None: the model's first keyframe, if any).

    Returns when the window is closed, or after `duration` simulated seconds when it is positive.
    No usable display raises UsageError suggesting sim_offscreen, Xvfb or DISPLAY. The engine comes from the
    backend named `backend` of `plugins`; a top-level entry point, so without `plugins` it finds them itself.
    """
    plugins = plugins or PluginHost.discover()
    with plugins.backend(backend).create_engine(Path(model_path), plugins) as engine:
        simulate(engine, keyframe=keyframe, duration=duration)


def simulate(engine: Engine, *, keyframe: str | None, duration: float, web: str | None = None) -> None:
    """Reset `engine` to the keyframe and run it in real time in the viewer until the window closes; with `web`
    ([HOST:]PORT) in a web page instead, until Ctrl-C (or `duration`)."""
    name = keyframe if keyframe else (engine.model.key(0).name if engine.model.nkey else None)
    try:
        engine.reset(name)
    except KeyError as error:
        raise ConfigError(f"simulation.keyframe: {error.args[0]}") from None
    held = f"held at keyframe '{name}' by its actuators" if name else "from its initial state"
    viewer: ViewerDisplay | InteractivePage
    if web is None:
        keys = _Controls()
        controls: _Controls | InteractiveControls = keys
        viewer = ViewerDisplay(engine.model, engine.data, key_callback=keys.on_key)
        print(
            f"MuJoCo viewer: {engine.model.nbody - 1} bodies, {held}. Space: pause/resume, Right: step while "
            "paused; close the window or press Ctrl-C to quit",
            flush=True,
        )
    else:
        # instead=None: a live simulation nobody can watch is no use, so an address it cannot listen on is an error
        page = open_interactive_page(engine.model, engine.data, web, title="JOSHUA interactive")
        viewer, controls = page, page.controls
        print(f"web display: {engine.model.nbody - 1} bodies, {held}; press Ctrl-C to quit", flush=True)
    try:
        _loop(engine, viewer, controls, duration, name)
    finally:
        viewer.close()


def _loop(
    engine: Engine,
    viewer: ViewerDisplay | InteractivePage,
    controls: _Controls | InteractiveControls,
    duration: float,
    keyframe: str | None,
) -> None:
    """Step the physics to keep up with the wall clock times the speed (not while paused), back to `keyframe` when
    asked, and sync the viewer each frame."""
    timestep = engine.timestep
    last = time.perf_counter()
    owed = 0.0  # simulated seconds the physics is behind the wall clock
    was_paused = False
    while duration <= 0 or engine.time < duration:
        now = time.perf_counter()
        elapsed, last = min(now - last, MAX_CATCH_UP_S), now
        with viewer.lock():
            if controls.take_reset():
                engine.reset(keyframe)
                owed = 0.0
            if controls.paused:
                steps = controls.take_steps()
            else:
                owed += elapsed * controls.speed
                steps = int(owed / timestep)
                owed -= steps * timestep
            if steps:
                engine.step(steps)
        if controls.paused != was_paused:
            was_paused = controls.paused
            viewer.set_status("PAUSED (Space: resume, Right: step)" if was_paused else "")
        if not viewer.update(engine.time):
            return
        time.sleep(max(0.0, FRAME_PERIOD_S - (time.perf_counter() - now)))


class InteractiveMode(Mode):
    """The viewer on the config's model; `keyframe` empty means the model's first keyframe."""

    def run(self, config: SimulationConfig, context: RunContext) -> None:
        viewer: ViewerOptions = context.settings("viewer", config)
        web = config.web if config.web or viewer.display == ViewerOptions.WEB else None
        with context.create_engine(config) as engine:
            simulate(engine, keyframe=config.keyframe or None, duration=config.duration, web=web)
