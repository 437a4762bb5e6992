"""JOSHUA's simulation modes OFFSCREEN, PASSIVE and INTERACTIVE, plus the pieces other modes reuse.

- `joshua_modes.offscreen`: `run_offscreen` (frames of a replayed trajectory) and `iter_offscreen_frames`.
- `joshua_modes.interactive`: `run_interactive` (the MuJoCo viewer, arm held at a keyframe).
- `joshua_modes.validation`: the trajectory checks against a model (the CSV reader is `joshua_core.trajectory`).

MP4 writing and "viewer window or headless recording" are in joshua-render (`joshua_render`), which
the modes, the mirror and the trainers share.

The package itself imports nothing heavy; the `joshua` entry point is `joshua_modes.plugin`. Other
plugins import only the names of `__all__` from here (loaded the first time one is used).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from joshua_modes.offscreen import frame_times, iter_offscreen_frames
    from joshua_modes.replay import model_joint_ranges

__all__ = ["frame_times", "iter_offscreen_frames", "model_joint_ranges"]

_HOME = {"frame_times": "offscreen", "iter_offscreen_frames": "offscreen", "model_joint_ranges": "replay"}


def __getattr__(name: str) -> Any:
    if name in _HOME:
        return getattr(importlib.import_module(f"joshua_modes.{_HOME[name]}"), name)
    raise AttributeError(f"module 'joshua_modes' has no attribute '{name}'")
