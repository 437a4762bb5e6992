"""JOSHUA's LeRobot plugin: LeRobot datasets (format v3.0) in and out.

- `LeRobotReader`: a `TrajectoryReader` (registered as "lerobot"), so passive replay, validation and every
  `load_trajectory` caller take a dataset folder as `trajectory_path`;
- `write_dataset`, `DatasetEpisode`: write episodes (joint positions, targets, camera frames) as a dataset;
- `LeRobotUnits`, `BodyUnits`, `read_calibration`, `feature_names`: LeRobot's names and units (both of
  `use_degrees`) <-> the model's, for anything that talks to an arm driven by LeRobot (`joshua deploy --units`);
- `export_trajectory`: a trajectory replayed on a model, rendered, written as a one-episode dataset
  (`joshua lerobot-export`, and the mirror's recording).

Importing the package is light: pyarrow and PyAV are imported the first time a name is used.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from joshua_lerobot.export import export_trajectory
    from joshua_lerobot.joints import BodyUnits, LeRobotUnits, feature_names, read_calibration
    from joshua_lerobot.reader import LeRobotReader
    from joshua_lerobot.writer import DatasetEpisode, write_dataset

__all__ = [
    "BodyUnits",
    "DatasetEpisode",
    "LeRobotReader",
    "LeRobotUnits",
    "export_trajectory",
    "feature_names",
    "read_calibration",
    "write_dataset",
]

_HOME = {
    "DatasetEpisode": "writer",
    "write_dataset": "writer",
    "LeRobotReader": "reader",
    "export_trajectory": "export",
    "BodyUnits": "joints",
    "LeRobotUnits": "joints",
    "feature_names": "joints",
    "read_calibration": "joints",
}


def __getattr__(name: str) -> Any:
    if name in _HOME:
        return getattr(importlib.import_module(f"joshua_lerobot.{_HOME[name]}"), name)
    raise AttributeError(f"module 'joshua_lerobot' has no attribute '{name}'")
