"""Choice of MuJoCo's OpenGL platform for rendering without a display (EGL, else OSMesa), and the one home of
"rendering is unavailable": its check, its message and its once-only warning where pictures are optional.

MuJoCo reads MUJOCO_GL once, when `mujoco` is first imported, so the choice is made before
joshua_render (and the MuJoCo backend, through it) imports it. The probes use ctypes only (no PyOpenGL,
no mujoco), so a failed probe leaves nothing behind that would stop the other platform from working.
A MUJOCO_GL that would make `import mujoco` itself fail (a value MuJoCo does not know, or a platform whose
library does not load) is replaced by `disable`, so that physics, training and evaluation run without GL; the
reason is kept and raised by the first renderer asked for.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys
from collections.abc import Callable
from typing import TypeVar

from joshua_core.errors import JoshuaError, UsageError

T = TypeVar("T")

# Debian packages each platform needs (setup.sh installs both sets).
EGL_PACKAGES = "libegl1 libgl1-mesa-dri libopengl0"
OSMESA_PACKAGES = "libosmesa6"

_EGL_PLATFORM_DEVICE_EXT = 0x313F
# MUJOCO_GL values MuJoCo accepts on Linux (mujoco/rendering/classic/gl_context.py); others fail its import
_DISABLED = ("disable", "disabled", "off", "false", "0")
_KNOWN = ("", "enable", "enabled", "on", "true", "1", "glfw", "glx", "egl", "osmesa", *_DISABLED)
FIX = (
    f"on Debian/Ubuntu install EGL: apt-get install {EGL_PACKAGES}; or OSMesa: apt-get install {OSMESA_PACKAGES} "
    "(./setup.sh installs both). MUJOCO_GL=egl or MUJOCO_GL=osmesa picks one; with a display, "
    "unset MUJOCO_GL to use it."
)


class RenderingUnavailableError(JoshuaError, RuntimeError):
    """No OpenGL platform could create a rendering context; the message names what to install."""


class InvalidGlPlatformError(UsageError, RenderingUnavailableError):
    """MUJOCO_GL names no platform MuJoCo knows: bad input (exit 2) where a picture is required."""


_unavailable: RenderingUnavailableError | None = None  # why nothing can be rendered in this process, once known
_warned = False  # render_optional's warning was printed


def has_display() -> bool:
    """True when an X11 or Wayland display is named in the environment (it may still be unreachable)."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def choose_headless_gl() -> str | None:
    """Set MUJOCO_GL when there is no display and the user has not chosen a platform; return the choice.

    EGL is used when its library can open a device display, else OSMesa when its library loads;
    when neither works EGL is kept (rendering then fails with `rendering_unavailable`'s message), or, when
    not even libEGL loads, `disable`. A MUJOCO_GL set by the user is kept unless `import mujoco` would fail
    with it (`_unusable`): then it becomes `disable` and `check_rendering` raises why. With a display,
    or with MUJOCO_GL set by the user, None is returned.

    If mujoco was imported first (as README's example does), MuJoCo has already picked GLFW,
    which needs a display; its renderer's context class is then swapped for the chosen one.
    """
    if "MUJOCO_GL" in os.environ:
        _disable_gl(_unusable(os.environ["MUJOCO_GL"]))
        return None
    if has_display():
        return None
    platform = "egl" if egl_works() else "osmesa" if osmesa_loads() else "egl"
    if not _loads("EGL", "libEGL.so.1") and platform == "egl":
        _disable_gl(RenderingUnavailableError(f"no OpenGL library to render without a display; {FIX}"))
        return os.environ.get("MUJOCO_GL")
    os.environ["MUJOCO_GL"] = platform
    if "mujoco" in sys.modules:
        _swap_context_class(platform)
    return platform


def _unusable(platform: str) -> RenderingUnavailableError | None:
    """Why `import mujoco` would fail with MUJOCO_GL=`platform`, or None: a value MuJoCo does not know, or EGL or
    OSMesa without its library (PyOpenGL then fails inside mujoco's import)."""
    value = platform.lower().strip()
    if value not in _KNOWN:
        return InvalidGlPlatformError(
            f"MUJOCO_GL={platform} is no OpenGL platform MuJoCo knows; set MUJOCO_GL=egl or MUJOCO_GL=osmesa "
            "(without a display), glfw (with one), or unset it"
        )
    if value == "egl" and not _loads("EGL", "libEGL.so.1") or value == "osmesa" and not osmesa_loads():
        return RenderingUnavailableError(f"MUJOCO_GL={value} needs a library that is missing; {FIX}")
    return None


def _disable_gl(reason: RenderingUnavailableError | None) -> None:
    """Keep `reason` (if any) as why nothing can be rendered, and let mujoco import without GL."""
    global _unavailable
    if reason is None:
        return
    _unavailable = reason
    if "mujoco" not in sys.modules:
        os.environ["MUJOCO_GL"] = "disable"


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
    return _loads("OSMesa", "libOSMesa.so.8")


def _loads(library: str, fallback: str) -> bool:
    """True if the shared library `library` (found as PyOpenGL finds it, else by the file name `fallback`) loads."""
    try:
        ctypes.CDLL(ctypes.util.find_library(library) or fallback)
    except OSError:
        return False
    return True


def check_rendering() -> None:
    """Raise why nothing can be rendered in this process, if that is known already (before any context is tried)."""
    if _unavailable is not None:
        raise _unavailable


def rendering_unavailable(error: BaseException) -> RenderingUnavailableError:
    """Note, and return to raise, that creating a rendering context failed: the cause and what to install (one line)."""
    global _unavailable
    platform = os.environ.get("MUJOCO_GL") or "glfw (MuJoCo's default, which needs a display)"
    cause = " ".join(f"{type(error).__name__}: {error}".split())
    _unavailable = RenderingUnavailableError(
        f"rendering failed with MUJOCO_GL={platform} ({cause}). Rendering without a display needs EGL or OSMesa; {FIX}"
    )
    return _unavailable


def render_optional(what: str, draw: Callable[[], T]) -> T | None:
    """`draw()`, or None where nothing can be rendered: pictures that are a by-product (training videos, eval
    videos) never end a run. The first failure warns once, on stderr, naming `what` is skipped and the fix;
    afterwards `draw` is not called at all (no rollouts for videos that cannot be drawn)."""
    global _unavailable, _warned
    if _unavailable is None:
        try:
            return draw()
        except RenderingUnavailableError as error:
            _unavailable = _unavailable or error
    if not _warned:
        _warned = True
        print(f"joshua: warning: no {what} (nor other pictures) in this run: {_unavailable}", file=sys.stderr)
    return None


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
