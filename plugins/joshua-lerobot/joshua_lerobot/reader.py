"""Reading one episode of a LeRobot dataset (format v3.0) as a `Trajectory` in the model's units:
`observation.state` -> positions, `action` -> targets (joshua_lerobot.joints maps names and units)."""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from joshua_core.interfaces import TrajectoryReader
from joshua_core.trajectory import Trajectory, TrajectoryError
from joshua_lerobot.joints import model_joint, to_model

INFO = "meta/info.json"
SUPPORTED_VERSION = "v3.0"
STATE, ACTION = "observation.state", "action"


class LeRobotReader(TrajectoryReader):
    """A LeRobot dataset folder: meta/info.json, meta/episodes/*/*.parquet, data/*/*.parquet."""

    def accepts(self, path: Path) -> bool:
        return (path / INFO).is_file()

    def read(self, path: Path, joints: Mapping[str, tuple[float, float]], *, episode: int = 0) -> Trajectory:
        info = _info(path)
        names = _names(path, info, STATE)
        row = _episode_row(path, episode)
        data = _episode_data(path, info, row, episode)
        order = np.argsort(data["frame_index"])
        joint_names = [model_joint(name, joints) for name in names]
        duplicates = sorted({joint for joint in joint_names if joint_names.count(joint) > 1})
        if duplicates:
            raise TrajectoryError(f"{path}: several of the dataset's joints map to {', '.join(duplicates)}")

        def convert(values: NDArray[Any]) -> NDArray[np.float64]:
            values = np.asarray(values, dtype=np.float64)[order]
            return np.stack(
                [
                    to_model(name, values[:, i], joints[joint])
                    for i, (name, joint) in enumerate(zip(names, joint_names, strict=True))
                ],
                axis=1,
            )

        targets = None
        if ACTION in data:
            if _names(path, info, ACTION) != names:
                raise TrajectoryError(f"{path}: '{ACTION}' names other joints than '{STATE}'; cannot pair them")
            targets = convert(data[ACTION])
        return Trajectory(
            path=path,
            joint_names=tuple(joint_names),
            timestamps=np.asarray(data["timestamp"], dtype=np.float64)[order],
            positions=convert(data[STATE]),
            lines=np.asarray(data["frame_index"], dtype=np.int64)[order],  # frame numbers stand in for lines
            targets=targets,
        )


def _info(path: Path) -> dict[str, Any]:
    try:
        info = json.loads((path / INFO).read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        raise TrajectoryError(f"{path / INFO}: cannot read the dataset's info: {error}") from None
    version = info.get("codebase_version")
    if version != SUPPORTED_VERSION:
        raise TrajectoryError(
            f"{path}: LeRobot dataset format {version}, this reader reads {SUPPORTED_VERSION}; convert it with "
            "lerobot's converter (python -m lerobot.datasets.v30.convert_dataset_v21_to_v30)"
        )
    return info


def _names(path: Path, info: dict[str, Any], key: str) -> list[str]:
    feature = info.get("features", {}).get(key)
    if not feature or not isinstance(feature.get("names"), list):
        raise TrajectoryError(f"{path / INFO}: no '{key}' feature with joint names")
    return [str(name) for name in feature["names"]]


def _episode_row(path: Path, episode: int) -> dict[str, Any]:
    """The episode's row of meta/episodes: where its frames lie."""
    import pyarrow.parquet as pq

    files = sorted((path / "meta/episodes").glob("*/*.parquet"))
    if not files:
        raise TrajectoryError(f"{path}: no meta/episodes/chunk-*/file-*.parquet")
    columns = ["episode_index", "data/chunk_index", "data/file_index", "length"]
    known = []
    for file in files:
        table = pq.read_table(file, columns=columns).to_pylist()
        for row in table:
            if row["episode_index"] == episode:
                return row
            known.append(row["episode_index"])
    raise TrajectoryError(f"{path}: no episode {episode}; the dataset has episodes 0..{max(known)} ({len(known)})")


def _episode_data(path: Path, info: dict[str, Any], row: dict[str, Any], episode: int) -> dict[str, Any]:
    """The episode's columns from its data file."""
    import pyarrow.dataset as ds

    file = path / info["data_path"].format(chunk_index=row["data/chunk_index"], file_index=row["data/file_index"])
    if not file.is_file():
        raise TrajectoryError(f"{path}: episode {episode}'s data file {file} is missing")
    dataset = ds.dataset(file, format="parquet")
    wanted = [name for name in ("timestamp", "frame_index", STATE, ACTION) if name in dataset.schema.names]
    if STATE not in wanted:
        raise TrajectoryError(f"{file}: no '{STATE}' column")
    table = dataset.to_table(columns=wanted, filter=ds.field("episode_index") == episode)
    if table.num_rows != row["length"]:
        raise TrajectoryError(
            f"{file}: episode {episode} has {table.num_rows} rows, meta/episodes says {row['length']}"
        )
    return {
        name: np.stack(column) if name in (STATE, ACTION) else np.asarray(column)
        for name, column in ((name, table.column(name).to_numpy(zero_copy_only=False)) for name in wanted)
    }
