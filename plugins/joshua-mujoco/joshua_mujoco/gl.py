"""Choice of MuJoCo's OpenGL platform for rendering without a display."""

from __future__ import annotations

import os
import sys


def choose_headless_gl() -> None:
    """Use EGL when there is no display and the user has not chosen a platform with MUJOCO_GL.

    MuJoCo reads MUJOCO_GL once, when `mujoco` is first imported, so this runs before
    joshua_mujoco imports it. If the user imported mujoco first (as the seed's snippet does),
    MuJoCo has already picked GLFW, which needs a display; its renderer's context class is then
    swapped for the EGL one before any renderer exists.
    """
    if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY") or "MUJOCO_GL" in os.environ:
        return
    os.environ["MUJOCO_GL"] = "egl"
    if "mujoco" not in sys.modules:
        return
    try:
        from mujoco.egl import GLContext
        from mujoco.rendering.classic import gl_context
    except ImportError:  # no EGL here: rendering will fail with the engine's own message
        return
    gl_context.GLContext = GLContext
