"""Choice of MuJoCo's OpenGL platform for rendering without a display."""

from __future__ import annotations

import os


def choose_headless_gl() -> None:
    """Use EGL when there is no display and the user has not chosen a platform with MUJOCO_GL.

    MuJoCo reads MUJOCO_GL once, when `mujoco` is first imported, so this runs before that import.
    """
    has_display = bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    if not has_display:
        os.environ.setdefault("MUJOCO_GL", "egl")
