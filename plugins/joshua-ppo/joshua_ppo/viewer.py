"""The live MuJoCo viewer of a PPO run (`training.ppo.viewer`): joshua_render's LiveViewer on the run's model."""

from __future__ import annotations

import mujoco

from joshua_ppo.options_pb2 import PpoOptions
from joshua_render import LiveViewer
from joshua_render import open_viewer as open_live_viewer

DEFAULT_VIEWER_ENVS = 4


def open_viewer(options: PpoOptions, model: mujoco.MjModel) -> LiveViewer | None:
    """The live viewer the options ask for: none for OFF; for AUTO when a display is usable; for ON, or a
    UsageError saying what to do without a display."""
    if options.viewer == PpoOptions.OFF:
        return None
    return open_live_viewer(
        model,
        options.viewer_envs or DEFAULT_VIEWER_ENVS,
        required=options.viewer == PpoOptions.ON,
        what="training.ppo.viewer ON (the live MuJoCo viewer)",
    )
