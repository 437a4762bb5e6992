"""The live training viewer: poses of a few environments in the MuJoCo viewer on a real X server (Xvfb)."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Callable

import mujoco
import numpy as np
import pytest
from numpy.typing import NDArray
from render_testing import SCENE, headless_env, orange_pixels

from joshua_core.errors import UsageError
from joshua_render import open_viewer

START_TIMEOUT_S = 60.0


def test_without_a_display_the_viewer_is_skipped_or_a_usage_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    model = mujoco.MjModel.from_xml_path(str(SCENE))
    assert open_viewer(model, 3, required=False, what="training.ppo.viewer ON") is None
    with pytest.raises(UsageError) as error:
        open_viewer(model, 3, required=True, what="training.ppo.viewer ON (the live MuJoCo viewer)")
    message = str(error.value)
    assert message.startswith("training.ppo.viewer ON (the live MuJoCo viewer) needs a display, but DISPLAY is not set")
    assert "sim_offscreen" in message and "Xvfb" in message


VIEWER_SCRIPT = f"""
import sys
import numpy as np
from joshua_render import open_viewer
import mujoco
model = mujoco.MjModel.from_xml_path({str(SCENE)!r})
home = model.key("home").qpos
viewer = open_viewer(model, 3, required=True, what="the test")
print(viewer.show(np.stack([home, home + 0.3, home - 0.3]), "iteration 1"), viewer.display.user_scene.ngeom, flush=True)
sys.stdin.readline()
viewer.close()
print("closed", flush=True)
"""


def test_live_viewer_shows_the_environments_and_closes_cleanly(
    xvfb: str, screenshot: Callable[[str], NDArray[np.uint8]]
) -> None:
    process = subprocess.Popen(
        [sys.executable, "-c", VIEWER_SCRIPT],
        env=headless_env(DISPLAY=xvfb),
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert process.stdout is not None and process.stdin is not None
        shown, ghost_geoms = process.stdout.readline().split()
        assert shown == "True" and int(ghost_geoms) > 10  # the 2nd and 3rd environments drawn into the scene
        deadline = time.monotonic() + START_TIMEOUT_S
        while orange_pixels(screenshot(xvfb)) < 300:  # the arm's printed parts are orange
            assert process.poll() is None, f"the viewer exited: {process.communicate()}"
            assert time.monotonic() < deadline, "the viewer did not show the arm within a minute"
            time.sleep(0.5)
        stdout, stderr = process.communicate("close\n", timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert process.returncode == 0, stderr
    assert stdout.split()[0] == "closed" and "Traceback" not in stderr
