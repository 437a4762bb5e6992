"""`mujoco.mjx`, imported without mujoco-mjx's notice that the optional Warp implementation is missing.

Without NVIDIA Warp installed, importing `mujoco.mjx` prints "Failed to import warp: ..." and
"Failed to import mujoco_warp: ..." to stdout. JOSHUA runs MJX's JAX implementation only, so those
lines are no error, yet they read like one at the top of every run and end up in piped output.
Only those two lines are dropped; anything else printed during the import still reaches stdout.
"""

from __future__ import annotations

import contextlib
import io
import sys

_WARP_NOTICES = ("Failed to import warp:", "Failed to import mujoco_warp:")

with contextlib.redirect_stdout(io.StringIO()) as _printed:
    from mujoco import mjx
for _line in _printed.getvalue().splitlines(keepends=True):
    if not _line.startswith(_WARP_NOTICES):
        sys.stdout.write(_line)

__all__ = ["mjx"]
