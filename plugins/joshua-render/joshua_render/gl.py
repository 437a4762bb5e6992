"""Choice of MuJoCo's OpenGL platform for rendering without a display: EGL, else OSMesa.

MuJoCo reads MUJOCO_GL once, when `mujoco` is first imported, so the choice is made before
joshua_render (and the MuJoCo backend, through it) imports it. The probes use ctypes only (no PyOpenGL,
no mujoco), so a failed probe leaves nothing behind that would stop the other platform from working.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys

from joshua_core.errors import JoshuaError

# Debian packages each platform needs (setup.sh installs both sets).
EGL_PACKAGES = "libegl1 libgl1-mesa-dri libopengl0"
OSMESA_PACKAGES = "libosmesa6"

_EGL_PLATFORM_DEVICE_EXT = 0x313F


class RenderingUnavailableError(JoshuaError, RuntimeError):
    """No OpenGL platform could create a rendering context; the message names what to install."""


def has_display() -> bool:
    """True when an X11 or Wayland display is named in the environment (it may still be unreachable)."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def choose_headless_gl() -> str | None:
    """Set MUJOCO_GL when there is no display and the user has not chosen a platform; return the choice.

    EGL is used when its library can open a device display, else OSMesa when its library loads;
    when neither works EGL is kept, and rendering fails with `rendering_unavailable`'s message.
    With a display, or with MUJOCO_GL set by the user, nothing changes and None is returned.

    If mujoco was imported first (as README's example does), MuJoCo has already picked GLFW,
    which needs a display; its renderer's context class is then swapped for the chosen one.
    """
    if has_display() or "MUJOCO_GL" in os.environ:
        return None
    platform = "egl" if egl_works() else "osmesa" if osmesa_loads() else "egl"
    os.environ["MUJOCO_GL"] = platform
    if "mujoco" in sys.modules:
        _swap_context_class(platform)
    return platform


def egl_works() -> bool:
    """True if libEGL loads and initializes a display on at least one EGL device."""
    try:
        egl = ctypes.CDLL("libEGL.so.1")
    except OSError:
        return False
    egl.eglGetProcAddress.restype = ctypes.c_void_p
    egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
    query_address = egl.eglGetProcAddress(b"eglQueryDevicesEXT")
    display_address = egl.eglGetProcAddress(b"eglGetPlatformDisplayEXT")
    if not query_address or not display_address:
        return False
    query_devices = ctypes.CFUNCTYPE(
        ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_int)
    )(query_address)
    platform_display = ctypes.CFUNCTYPE(ctypes.c_void_p, ctypes.c_uint, ctypes.c_void_p, ctypes.c_void_p)(
        display_address
    )
    egl.eglInitialize.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
    egl.eglInitialize.restype = ctypes.c_uint
    egl.eglTerminate.argtypes = [ctypes.c_void_p]
    devices = (ctypes.c_void_p * 16)()
    count = ctypes.c_int(0)
    if not query_devices(16, devices, ctypes.byref(count)):
        return False
    for device in devices[: count.value]:
        display = platform_display(_EGL_PLATFORM_DEVICE_EXT, device, None)
        if display and egl.eglInitialize(display, None, None):
            egl.eglTerminate(display)
            return True
    return False


def osmesa_loads() -> bool:
    """True if the OSMesa library (Debian: libosmesa6) can be loaded."""
    name = ctypes.util.find_library("OSMesa") or "libOSMesa.so.8"
    try:
        ctypes.CDLL(name)
    except OSError:
        return False
    return True


def rendering_unavailable(error: BaseException) -> RenderingUnavailableError:
    """The error to raise when creating a rendering context failed: the cause and what to install."""
    platform = os.environ.get("MUJOCO_GL") or "glfw (MuJoCo's default, which needs a display)"
    return RenderingUnavailableError(
        f"rendering failed with MUJOCO_GL={platform} ({type(error).__name__}: {error}). "
        "Rendering without a display needs EGL or OSMesa; on Debian/Ubuntu install "
        f"EGL: apt-get install {EGL_PACKAGES}; or OSMesa: apt-get install {OSMESA_PACKAGES} "
        "(./setup.sh installs both). MUJOCO_GL=egl or MUJOCO_GL=osmesa picks one; with a display, "
        "unset MUJOCO_GL to use it."
    )


def _swap_context_class(platform: str) -> None:
    """Make renderers created from now on use `platform`, although mujoco was imported with GLFW."""
    try:
        from mujoco.rendering.classic import gl_context

        if platform == "egl":
            from mujoco.egl import GLContext
        else:
            from mujoco.osmesa import GLContext
    except (ImportError, AttributeError):  # PyOpenGL without the library; rendering fails with rendering_unavailable
        return
    gl_context.GLContext = GLContext
