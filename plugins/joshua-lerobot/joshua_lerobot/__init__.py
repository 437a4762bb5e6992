"""JOSHUA's LeRobot plugin: LeRobot datasets (format v3.0) in and out.

- `LeRobotReader`: a `TrajectoryReader` (registered as "lerobot"), so passive replay, validation and every
  `load_trajectory` caller take a dataset folder as `trajectory_path`;
- `write_dataset`, `DatasetEpisode`: write episodes (joint positions, targets, camera frames) as a dataset;
- `export_trajectory`: a trajectory replayed on a model, rendered, written as a one-episode dataset
  (`joshua lerobot-export`, and the mirror's recording).

Importing the package is light: pyarrow and PyAV are imported the first time a name is used.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from joshua_lerobot.export import export_trajectory
    from joshua_lerobot.reader import LeRobotReader
    from joshua_lerobot.writer import DatasetEpisode, write_dataset

__all__ = ["DatasetEpisode", "LeRobotReader", "export_trajectory", "write_dataset"]

_HOME = {
    "DatasetEpisode": "writer",
    "write_dataset": "writer",
    "LeRobotReader": "reader",
    "export_trajectory": "export",
}


def __getattr__(name: str) -> Any:
    if name in _HOME:
        return getattr(importlib.import_module(f"joshua_lerobot.{_HOME[name]}"), name)
    raise AttributeError(f"module 'joshua_lerobot' has no attribute '{name}'")
