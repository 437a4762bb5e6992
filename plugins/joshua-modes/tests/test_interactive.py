"""INTERACTIVE for real: the viewer under Xvfb, screenshots of the X screen, Ctrl-C and closing the window."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from modes_testing import JOSHUA_SCRIPT, distinct_colours, headless_env, orange_pixels
from numpy.typing import NDArray

BANNER = "MuJoCo viewer: "
START_TIMEOUT_S = 60.0
Screenshot = Callable[[str], NDArray[np.uint8]]  # the root conftest's fixture `screenshot`


def launch(display: str, cwd: Path, *args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [str(JOSHUA_SCRIPT), "--preset", "so_arm100_sim_interactive", *args],
        cwd=cwd,
        env=headless_env(DISPLAY=display),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def wait_for_robot(display: str, process: subprocess.Popen[str], screenshot: Screenshot) -> np.ndarray:
    """Screenshots until the viewer shows the orange arm; fails if the process dies or time runs out."""
    deadline = time.monotonic() + START_TIMEOUT_S
    while True:
        assert process.poll() is None, f"joshua exited with {process.returncode}: {process.communicate()}"
        shot = screenshot(display)
        if orange_pixels(shot) > 300:
            return shot
        assert time.monotonic() < deadline, "the viewer did not show the arm within a minute"
        time.sleep(0.5)


def finish(process: subprocess.Popen[str]) -> tuple[int, str, str]:
    try:
        stdout, stderr = process.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        process.kill()
        stdout, stderr = process.communicate()
        raise AssertionError(f"joshua did not exit within 30 s; stderr: {stderr}") from None
    return process.returncode, stdout, stderr


def assert_clean(stderr: str) -> None:
    for sign in ("Traceback", "X Error", "Segmentation fault", "Fatal Python error", "core dumped"):
        assert sign not in stderr, stderr


def test_viewer_shows_the_arm_and_ctrl_c_exits_cleanly(xvfb: str, screenshot: Screenshot, tmp_path: Path) -> None:
    blank = screenshot(xvfb)
    assert distinct_colours(blank) <= 2  # an empty X screen
    process = launch(xvfb, tmp_path)
    try:
        shot = wait_for_robot(xvfb, process, screenshot)
    finally:
        process.send_signal(signal.SIGINT)
    status, stdout, stderr = finish(process)
    assert distinct_colours(shot) > 1000 and np.abs(shot.astype(int) - blank).mean() > 10
    assert stdout.startswith(BANNER) and "held at keyframe 'home' by its actuators" in stdout
    assert status == 130 and stderr.strip().endswith("joshua: interrupted")
    assert_clean(stderr)


def test_closing_the_window_ends_the_run_with_status_0(xvfb: str, screenshot: Screenshot, tmp_path: Path) -> None:
    xdotool = shutil.which("xdotool")
    assert xdotool, "xdotool is not installed; ./setup.sh --dev installs it"
    process = launch(xvfb, tmp_path)
    try:
        wait_for_robot(xvfb, process, screenshot)
        window = subprocess.run(
            [xdotool, "search", "--name", "^MuJoCo"], env=headless_env(DISPLAY=xvfb), capture_output=True, text=True
        ).stdout.split()
        assert window, "no MuJoCo window found"
        subprocess.run(  # the viewer's Quit shortcut: it closes the window as the title bar's X button would
            [xdotool, "windowfocus", "--sync", window[0], "key", "ctrl+q"], env=headless_env(DISPLAY=xvfb), check=True
        )
        status, _, stderr = finish(process)
    finally:
        if process.poll() is None:
            process.kill()
    assert status == 0, stderr
    assert_clean(stderr)


HOLD_PROBE = """
import numpy as np
from numpy.typing import NDArray
from joshua_mujoco import MuJoCoEngine
from joshua_modes.interactive import simulate
with MuJoCoEngine("so_arm100/scene.xml") as engine:
    simulate(engine, keyframe=None, duration=1.5)
    key = engine.model.key("home")
    print(engine.time, np.abs(engine.data.qpos - key.qpos).max(), np.array_equal(engine.data.ctrl, key.ctrl))
"""


def test_the_arm_is_held_at_home_by_its_actuators(xvfb: str) -> None:
    result = subprocess.run(
        [sys.executable, "-c", HOLD_PROBE], env=headless_env(DISPLAY=xvfb), capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0, result.stderr
    sim_time, drift, ctrl_is_home = result.stdout.split()[-3:]
    assert float(sim_time) >= 1.5 and float(drift) < 0.01 and ctrl_is_home == "True"
    assert_clean(result.stderr)


def test_no_display_suggests_offscreen_xvfb_or_display(tmp_path: Path) -> None:
    result = subprocess.run(
        [str(JOSHUA_SCRIPT), "--preset", "so_arm100_sim_interactive"],
        cwd=tmp_path,
        env=headless_env(),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2
    assert result.stderr.startswith("joshua: error: the MuJoCo viewer needs a display, but DISPLAY is not set")
    assert "sim_offscreen" in result.stderr and "Xvfb" in result.stderr and "DISPLAY=" in result.stderr


def test_the_viewer_opens_a_usd_robot(xvfb: str, screenshot: Screenshot, tmp_path: Path) -> None:
    """model_path may name a USD file (joshua-usd's reader): the exported SO-ARM100, robot only (no keyframes, no
    lights: only MuJoCo's headlight, so the test looks for the window, not the arm's colour)."""
    blank = screenshot(xvfb)
    process = launch(xvfb, tmp_path, "--set", "simulation.model_path=isaac/so100.usd", "--set", "simulation.keyframe=")
    assert process.stdout is not None
    try:
        assert process.stdout.readline().startswith(BANNER)  # the viewer is up
        deadline = time.monotonic() + START_TIMEOUT_S
        while (changed := np.abs(screenshot(xvfb).astype(int) - blank).mean()) < 1 and time.monotonic() < deadline:
            time.sleep(0.5)
    finally:
        process.send_signal(signal.SIGINT)
    status, _, stderr = finish(process)
    assert changed >= 1, "the viewer window never appeared"
    assert status == 130 and stderr.strip().endswith("joshua: interrupted")
    assert_clean(stderr)
