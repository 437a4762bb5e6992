"""Writing LeRobot datasets in format v3.0, the layout lerobot 0.4.4's `LeRobotDataset` reads:

    meta/info.json                          features, fps, totals, path templates
    meta/stats.json                         statistics of every feature over the dataset
    meta/tasks.parquet                      task text (the pandas index) -> task_index
    meta/episodes/chunk-000/file-000.parquet   per episode: length, rows, video spans, statistics
    data/chunk-000/file-000.parquet         one row per frame: observation.state, action, indices
    videos/<camera key>/chunk-000/file-000.mp4 every episode's frames, one after the other

Everything goes into one chunk and file per kind (LeRobot starts a new file at 100 MB of data or 200 MB
of video; a simulated rollout stays far below). The folder is written whole or not at all.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from joshua_core.atomic import atomic_write_json
from joshua_core.errors import UsageError
from joshua_core.outputs import output_folder
from joshua_lerobot import stats as statistics
from joshua_lerobot.joints import DEFAULT_UNITS, LeRobotUnits, feature_names, units_metadata
from joshua_lerobot.video import CODEC_NAME, PIXEL_FORMAT, Mp4Writer

CODEBASE_VERSION = "v3.0"
STATE, ACTION = "observation.state", "action"
CAMERA_PREFIX = "observation.images."
CHUNKS_SIZE, DATA_FILE_MB, VIDEO_FILE_MB = 1000, 100, 200  # LeRobot's defaults, recorded in info.json
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
VIDEO_PATH = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
EPISODES_PATH = "meta/episodes/chunk-000/file-000.parquet"
FIRST_FILE = {"chunk_index": 0, "file_index": 0}
INDEX_FEATURES = ("timestamp", "frame_index", "episode_index", "index", "task_index")


@dataclass(frozen=True)
class DatasetEpisode:
    """One episode in the model's units: `states` and `actions` (frames, joints) at `timestamps` (i / fps),
    and per camera an iterable yielding one (H, W, 3) uint8 RGB frame per row (rendered while written)."""

    joint_names: tuple[str, ...]
    timestamps: NDArray[np.float64]
    states: NDArray[np.float64]
    actions: NDArray[np.float64]
    task: str
    cameras: Mapping[str, Iterable[NDArray[np.uint8]]] = field(default_factory=dict)

    @property
    def length(self) -> int:
        return len(self.timestamps)


def write_dataset(
    path: Path,
    episodes: Iterable[DatasetEpisode],
    *,
    fps: int,
    joint_ranges: Mapping[str, tuple[float, float]],
    units: LeRobotUnits = DEFAULT_UNITS,
    overwrite: bool = False,
    option: str = "--out",
) -> Path:
    """Write `episodes` (same joints and cameras each) as a LeRobot dataset folder at `path`; joint values are
    converted to LeRobot's names and `units` (joshua_lerobot.joints), which info.json records. The episodes are
    taken one at a time, each encoded before the next is asked for, so an iterable that makes them as it goes
    (a rollout) holds one episode's frames at a time. A folder there is only replaced when joshua wrote it and
    `overwrite` is set (`joshua_core.outputs.output_folder`; `option` names `path` in errors); an error on the
    way, the iterable's own included, leaves nothing there."""
    with output_folder(path, overwrite=overwrite, option=option) as folder:
        layout = _Layout(folder, joint_ranges, units, fps)
        try:
            for episode in episodes:
                layout.add(episode)
        finally:
            layout.close_videos()
        layout.finish()
    return path


class _Layout:
    """The files of one dataset being written, episode by episode, and the statistics gathered on the way."""

    def __init__(self, folder: Path, joint_ranges: Mapping[str, tuple[float, float]], units: LeRobotUnits, fps: int):
        self.folder, self.ranges, self.units, self.fps = folder, joint_ranges, units, fps
        self.first: DatasetEpisode | None = None
        self.names: list[str] = []
        self.robot_type: str | None = None
        self.tasks: list[str] = []
        self.lengths: list[int] = []
        self.episode_tasks: list[str] = []
        self.episode_stats: list[dict[str, dict[str, NDArray[Any]]]] = []
        self.pixel_samples: dict[str, list[NDArray[np.float64]]] = {}
        self.video_shapes: dict[str, tuple[int, int]] = {}
        self.videos: dict[str, Mp4Writer] = {}
        self.columns: dict[str, list[NDArray[Any]]] = {}

    def add(self, episode: DatasetEpisode) -> None:
        """Encode `episode`'s frames after the earlier episodes' and keep its rows for the data file."""
        if self.first is None:
            self.first = episode
            self.names, self.robot_type = feature_names(episode.joint_names)
        elif episode.joint_names != self.first.joint_names or set(episode.cameras) != set(self.first.cameras):
            raise UsageError("every episode of a dataset needs the same joints and cameras")
        if episode.task not in self.tasks:
            self.tasks.append(episode.task)
        stats = self.add_videos(episode)
        stats |= self.add_rows(episode)
        self.episode_stats.append(stats)
        self.lengths.append(episode.length)
        self.episode_tasks.append(episode.task)

    def lerobot_values(self, values: NDArray[np.float64]) -> NDArray[np.float32]:
        """(frames, joints) model values in LeRobot's units, float32."""
        assert self.first is not None
        columns = [
            self.units.from_model(name, values[:, i], self.ranges[joint])
            for i, (name, joint) in enumerate(zip(self.names, self.first.joint_names, strict=True))
        ]
        return np.stack(columns, axis=1).astype(np.float32)

    def add_videos(self, episode: DatasetEpisode) -> dict[str, dict[str, NDArray[Any]]]:
        """Encode every camera's frames of `episode`; its per-camera pixel statistics."""
        stats = {}
        for camera, frames in episode.cameras.items():
            key = CAMERA_PREFIX + camera
            samples = []
            for frame in frames:
                writer = self.videos.get(key)
                if writer is None:
                    path = self.folder / VIDEO_PATH.format(video_key=key, **FIRST_FILE)
                    path.parent.mkdir(parents=True, exist_ok=True)
                    self.video_shapes[key] = frame.shape[:2]
                    writer = self.videos[key] = Mp4Writer(path, self.fps, frame.shape[1], frame.shape[0])
                writer.write(frame)
                samples.append(statistics.image_sample(frame))
            if len(samples) != episode.length:
                raise UsageError(f"camera '{camera}' gave {len(samples)} frames for {episode.length} rows")
            stats[key] = statistics.image_stats(samples, len(samples))
            self.pixel_samples.setdefault(key, []).extend(samples)
        return stats

    def add_rows(self, episode: DatasetEpisode) -> dict[str, dict[str, NDArray[Any]]]:
        """`episode`'s rows of the data file (one per frame); their statistics."""
        length, start = episode.length, sum(self.lengths)
        columns = {
            STATE: self.lerobot_values(episode.states),
            ACTION: self.lerobot_values(episode.actions),
            "timestamp": episode.timestamps.astype(np.float32),
            "frame_index": np.arange(length, dtype=np.int64),
            "episode_index": np.full(length, len(self.lengths), dtype=np.int64),
            "index": np.arange(start, start + length, dtype=np.int64),
            "task_index": np.full(length, self.tasks.index(episode.task), dtype=np.int64),
        }
        for key, values in columns.items():
            self.columns.setdefault(key, []).append(values)
        return {key: statistics.vector_stats(values) for key, values in columns.items()}

    def close_videos(self) -> None:
        for writer in self.videos.values():
            writer.close()

    def finish(self) -> None:
        """The data file and the metadata, once every episode is in."""
        if self.first is None:
            raise UsageError("a LeRobot dataset needs at least one episode")
        self.write_data()
        recorded_units = units_metadata(self.units) if self.robot_type else None
        info = _info(
            self.lengths, self.names, self.video_shapes, self.fps, self.robot_type, len(self.tasks), recorded_units
        )
        atomic_write_json(self.folder / "meta/info.json", info)
        atomic_write_json(self.folder / "meta/stats.json", statistics.as_json(self.dataset_stats()))
        _write_tasks(self.folder / "meta/tasks.parquet", self.tasks)
        self.write_episodes()

    def write_data(self) -> None:
        """data/chunk-000/file-000.parquet: one row per frame."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        joined = {key: np.concatenate(parts) for key, parts in self.columns.items()}
        width = len(self.names)
        arrays = {
            key: pa.FixedSizeListArray.from_arrays(pa.array(values.reshape(-1)), width) if values.ndim == 2 else values
            for key, values in joined.items()
        }
        table = pa.table(arrays).replace_schema_metadata({"huggingface": json.dumps(_hf_features(width))})
        path = self.folder / DATA_PATH.format(**FIRST_FILE)
        path.parent.mkdir(parents=True, exist_ok=True)
        pq.write_table(table, path)

    def dataset_stats(self) -> dict[str, dict[str, NDArray[Any]]]:
        joined = {key: statistics.vector_stats(np.concatenate(parts)) for key, parts in self.columns.items()}
        frames = sum(self.lengths)
        cameras = {key: statistics.image_stats(samples, frames) for key, samples in self.pixel_samples.items()}
        return joined | cameras

    def write_episodes(self) -> None:
        """meta/episodes/chunk-000/file-000.parquet: where each episode's rows and video span lie, its stats."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        rows: list[dict[str, Any]] = []
        start = 0
        for index, (length, task) in enumerate(zip(self.lengths, self.episode_tasks, strict=True)):
            row: dict[str, Any] = {
                "episode_index": index,
                "tasks": [task],
                "length": length,
                "data/chunk_index": 0,
                "data/file_index": 0,
                "dataset_from_index": start,
                "dataset_to_index": start + length,
            }
            for key in self.pixel_samples:
                row |= {
                    f"videos/{key}/chunk_index": 0,
                    f"videos/{key}/file_index": 0,
                    f"videos/{key}/from_timestamp": start / self.fps,
                    f"videos/{key}/to_timestamp": (start + length) / self.fps,
                }
            for feature, by_stat in self.episode_stats[index].items():
                row |= {f"stats/{feature}/{stat}": value.tolist() for stat, value in by_stat.items()}
            rows.append(row | {"meta/episodes/chunk_index": 0, "meta/episodes/file_index": 0})
            start += length
        path = self.folder / EPISODES_PATH
        path.parent.mkdir(parents=True, exist_ok=True)
        pq.write_table(pa.Table.from_pylist(rows), path)


def _hf_features(width: int) -> dict[str, Any]:
    """The `huggingface` schema metadata of the data file, as the `datasets` library writes it."""
    vector = {"feature": {"dtype": "float32", "_type": "Value"}, "length": width, "_type": "List"}
    scalars = {"timestamp": "float32", "frame_index": "int64", "episode_index": "int64", "index": "int64"}
    features = {STATE: vector, ACTION: vector} | {
        key: {"dtype": dtype, "_type": "Value"} for key, dtype in (scalars | {"task_index": "int64"}).items()
    }
    return {"info": {"features": features}}


def _write_tasks(path: Path, tasks: list[str]) -> None:
    """meta/tasks.parquet: `task_index` with the task text as the pandas index (as LeRobot's DataFrame has it)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    index = "__index_level_0__"
    pandas = {
        "index_columns": [index],
        "column_indexes": [],
        "columns": [
            {
                "name": "task_index",
                "field_name": "task_index",
                "pandas_type": "int64",
                "numpy_type": "int64",
                "metadata": None,
            },
            {"name": None, "field_name": index, "pandas_type": "unicode", "numpy_type": "object", "metadata": None},
        ],
        "pandas_version": "2.3.3",
    }
    table = pa.table({"task_index": np.arange(len(tasks), dtype=np.int64), index: tasks})
    pq.write_table(table.replace_schema_metadata({"pandas": json.dumps(pandas)}), path)


def _info(
    lengths: Sequence[int],
    names: list[str],
    video_shapes: Mapping[str, tuple[int, int]],
    fps: int,
    robot_type: str | None,
    total_tasks: int,
    units: dict[str, Any] | None,
) -> dict[str, Any]:
    vector: dict[str, Any] = {"dtype": "float32", "shape": [len(names)], "names": names}
    if units is not None:
        vector["units"] = units
    features: dict[str, Any] = {STATE: vector, ACTION: vector}
    for key, (height, width) in video_shapes.items():
        features[key] = {
            "dtype": "video",
            "shape": [height, width, 3],
            "names": ["height", "width", "channels"],
            "info": {
                "video.height": height,
                "video.width": width,
                "video.codec": CODEC_NAME,
                "video.pix_fmt": PIXEL_FORMAT,
                "video.is_depth_map": False,
                "video.fps": fps,
                "video.channels": 3,
                "has_audio": False,
            },
        }
    for key in INDEX_FEATURES:
        features[key] = {"dtype": "float32" if key == "timestamp" else "int64", "shape": [1], "names": None}
    return {
        "codebase_version": CODEBASE_VERSION,
        "robot_type": robot_type,
        "total_episodes": len(lengths),
        "total_frames": sum(lengths),
        "total_tasks": total_tasks,
        "chunks_size": CHUNKS_SIZE,
        "data_files_size_in_mb": DATA_FILE_MB,
        "video_files_size_in_mb": VIDEO_FILE_MB,
        "fps": fps,
        "splits": {"train": f"0:{len(lengths)}"},
        "data_path": DATA_PATH,
        "video_path": VIDEO_PATH if video_shapes else None,
        "features": features,
    }
