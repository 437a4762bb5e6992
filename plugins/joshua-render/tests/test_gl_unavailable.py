"""Rendering made impossible for real (an unknown MUJOCO_GL, an EGL without a driver), in fresh processes: mujoco
still imports, a picture that is required fails in one line naming the fix, an optional one warns once."""

from __future__ import annotations

import subprocess
import sys

from render_testing import SCENE, headless_env

NO_EGL_DRIVER = {"MUJOCO_GL": "egl", "__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent/egl_vendor.json"}
PROBE = f"""
from joshua_render import RenderingUnavailableError, create_renderer, render_optional
import mujoco
model = mujoco.MjModel.from_xml_path({str(SCENE)!r})
for _ in range(2):
    assert render_optional("test pictures", lambda: create_renderer(model, 32, 24)) is None
try:
    create_renderer(model, 32, 24)
except RenderingUnavailableError as error:
    print(error.exit_code, error)
"""


def probe(**env: str) -> tuple[str, list[str]]:
    """The probe's stdout (exit status and message of a required picture) and its stderr lines."""
    done = subprocess.run(
        [sys.executable, "-c", PROBE], env=headless_env(**env), capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    return done.stdout.strip(), done.stderr.splitlines()


def test_unknown_mujoco_gl_leaves_mujoco_importable_and_names_mujoco_gl() -> None:
    required, warnings = probe(MUJOCO_GL="bogus")
    assert required == (
        "2 MUJOCO_GL=bogus is no OpenGL platform MuJoCo knows; set MUJOCO_GL=egl or MUJOCO_GL=osmesa "
        "(without a display), glfw (with one), or unset it"
    )
    assert warnings == [f"joshua: warning: no test pictures (nor other pictures) in this run: {required[2:]}"]


def test_egl_without_a_driver_warns_once_with_the_packages_to_install() -> None:
    required, warnings = probe(**NO_EGL_DRIVER)
    assert required.startswith("1 rendering failed with MUJOCO_GL=egl (") and "\n" not in required
    assert "apt-get install libegl1 libgl1-mesa-dri libopengl0" in required and "libosmesa6" in required
    assert warnings == [f"joshua: warning: no test pictures (nor other pictures) in this run: {required[2:]}"]


def test_a_mode_that_must_render_refuses_an_unknown_mujoco_gl_in_one_line() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "joshua_core.cli", "--preset", "sim_offscreen", "--set", "simulation.duration=0.1"],
        env=headless_env(MUJOCO_GL="bogus"),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert done.stderr.strip().splitlines()[-1].startswith("joshua: error: MUJOCO_GL=bogus is no OpenGL platform")
    assert "Traceback" not in done.stderr
