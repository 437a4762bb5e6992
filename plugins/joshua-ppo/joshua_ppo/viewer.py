"""The live displays of a PPO run: the MuJoCo viewer (`training.ppo.viewer`, joshua_render's LiveViewer) and the web
page (`training.web`, `--web`, joshua_render's TrainingPage), both on the run's model."""

from __future__ import annotations

import mujoco

from joshua_core.config_pb2 import TrainingConfig
from joshua_ppo.settings import RunSettings
from joshua_render import LiveViewer, TrainingPage, open_training_page
from joshua_render import open_viewer as open_live_viewer

PAGE_ENVS = 4  # environments the web page shows side by side (fewer when the run has fewer)


def open_viewer(run: RunSettings, model: mujoco.MjModel, owner: str) -> LiveViewer | None:
    """The live viewer a run's settings ask for (the options of a trainer at `owner` in a config): none for off; for
    auto when a display is usable; for on, or a UsageError saying what to do without a display."""
    if run.viewer == "off":
        return None
    return open_live_viewer(
        model,
        run.viewer_envs,
        required=run.viewer == "on",
        what=f"{owner}.viewer ON (the live MuJoCo viewer)",
    )


def open_page(config: TrainingConfig, model: mujoco.MjModel, num_envs: int, title: str) -> TrainingPage | None:
    """The web page at `config.web` (None when unset, or when it cannot listen there: training goes on, and says so)."""
    if not config.web:
        return None
    return open_training_page(model, min(PAGE_ENVS, num_envs), config.web, title=title)
