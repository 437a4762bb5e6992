"""Reading one episode of a LeRobot dataset (format v3.0) as a `Trajectory` in the model's units:
`observation.state` -> positions, `action` -> targets (joshua_lerobot.joints maps names and units).

Every input is checked by type and shape before it is used, and each problem is a TrajectoryError naming the
file and the field: a dataset is data from elsewhere, and a wrong read (a dropped joint, a file outside the
dataset) must not pass for a replay of it.
"""

from __future__ import annotations

import json
import string
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from joshua_core.atomic import atomic_write_bytes
from joshua_core.errors import UsageError
from joshua_core.interfaces import TrajectoryReader
from joshua_core.json_files import read_json_object
from joshua_core.trajectory import Trajectory, TrajectoryError
from joshua_lerobot.joints import (
    DEFAULT_UNITS,
    GRIPPER,
    RANGE_SCALE,
    SO100_JOINTS,
    LeRobotUnits,
    model_joint,
    plausible_bound,
    units_from_metadata,
    units_metadata,
)

INFO = "meta/info.json"
EPISODES = "meta/episodes"
SUPPORTED_VERSION = "v3.0"
STATE, ACTION = "observation.state", "action"
EPISODE_COLUMNS = ("episode_index", "data/chunk_index", "data/file_index", "length")
DATA_PATH_FIELDS = {"chunk_index", "file_index"}
RANGE_TOLERANCE = 1e-6  # rad: a value this close to its joint's limit is within it (float32 in the dataset)


class LeRobotReader(TrajectoryReader):
    """A LeRobot dataset folder: meta/info.json, meta/episodes/*/*.parquet, data/*/*.parquet."""

    def accepts(self, path: Path) -> bool:
        return (path / INFO).is_file()

    def read(self, path: Path, joints: Mapping[str, tuple[float, float]], *, episode: int = 0) -> Trajectory:
        info = _info(path)
        names = _names(path, info, STATE)
        action_names = _names(path, info, ACTION) if ACTION in info["features"] else None
        if action_names is not None and action_names != names:
            raise TrajectoryError(f"{path / INFO}: '{ACTION}' names other joints than '{STATE}'; cannot pair them")
        units, recorded = _units(path, info)
        row = _episode_row(path, episode)
        file, data = _episode_data(path, info, row, episode, names)
        order = np.argsort(data["frame_index"], kind="stable")
        joint_names = []
        for name in names:
            try:
                joint_names.append(model_joint(name, joints))
            except TrajectoryError as error:
                raise TrajectoryError(f"{path / INFO}: features.{STATE}.names: {error}") from None
        duplicates = sorted({joint for joint in joint_names if joint_names.count(joint) > 1})
        if duplicates:
            raise TrajectoryError(f"{path}: several of the dataset's joints map to {', '.join(duplicates)}")

        def convert(values: NDArray[np.float64]) -> NDArray[np.float64]:
            values = values[order]
            return np.stack(
                [
                    units.to_model(name, values[:, i], joints[joint])
                    for i, (name, joint) in enumerate(zip(names, joint_names, strict=True))
                ],
                axis=1,
            )

        positions = convert(data[STATE])
        if not recorded:
            _hint_range_units(path, names, data[STATE], positions, [joints[joint] for joint in joint_names])
        return Trajectory(
            path=path,
            joint_names=tuple(joint_names),
            timestamps=data["timestamp"][order],
            positions=positions,
            lines=data["frame_index"][order],  # frame numbers stand in for lines
            targets=convert(data[ACTION]) if ACTION in data else None,
        )


def _info(path: Path) -> dict[str, Any]:
    """meta/info.json, checked: an object with the supported version, `features` an object, `data_path` text."""
    file = path / INFO
    info = read_json_object(file, "the dataset's info", TrajectoryError)
    version = info.get("codebase_version")
    if version != SUPPORTED_VERSION:
        raise TrajectoryError(
            f"{path}: LeRobot dataset format {version}, this reader reads {SUPPORTED_VERSION}; convert it with "
            "lerobot's converter (python -m lerobot.datasets.v30.convert_dataset_v21_to_v30)"
        )
    if not isinstance(info.get("features"), dict):
        raise TrajectoryError(f"{file}: 'features' is missing or not an object")
    if not isinstance(info.get("data_path"), str):
        raise TrajectoryError(
            f"{file}: 'data_path' is missing or not a string (a path template such as "
            "'data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet')"
        )
    return info


def _units(path: Path, info: dict[str, Any]) -> tuple[LeRobotUnits, bool]:
    """The units the state feature (checked by `_names`) records, and whether it records them: joshua's writer
    and `joshua lerobot-units` note them (`units_metadata`). lerobot records none (its info.json does not say
    which `use_degrees` the follower had), so without a record the values are read in lerobot's default,
    degrees (`use_degrees=True`)."""
    recorded = info["features"][STATE].get("units")
    if recorded is None:
        return DEFAULT_UNITS, False
    return units_from_metadata(recorded, f"{path / INFO}: features.{STATE}.units"), True


def _hint_range_units(
    path: Path,
    names: list[str],
    values: NDArray[np.float64],
    positions: NDArray[np.float64],
    ranges: list[tuple[float, float]],
) -> None:
    """One line on stderr when the SO-100 body values of a dataset without a units record look like lerobot's
    range units (use_degrees=False): all within -100..100, yet some outside their joint's range as degrees."""
    body = [i for i, name in enumerate(names) if name in SO100_JOINTS and name != GRIPPER]
    if not body or not (np.abs(values[:, body]) <= RANGE_SCALE).all():
        return
    low, high = (np.array([ranges[i][end] for i in body]) for end in (0, 1))
    beyond = (positions[:, body] < low - RANGE_TOLERANCE) | (positions[:, body] > high + RANGE_TOLERANCE)
    outside = [names[i] for i, out in zip(body, beyond.any(axis=0), strict=True) if out]
    if outside:
        print(
            f"joshua: hint: {path}: {', '.join(outside)} leave their joint range read as degrees, but every body "
            "value lies within -100..100: if the arm recorded with use_degrees=False, say so once with "
            f"joshua lerobot-units {path} --units range --calibration JSON",
            file=sys.stderr,
        )


def record_units(path: Path, units: LeRobotUnits, *, overwrite: bool = False) -> bool:
    """Note `units` in the dataset's meta/info.json (the state and action features' `units`, as joshua's writer
    does), so that every reader of the dataset converts with them; lerobot ignores the key. Returns whether the
    file changed. A record already there that says otherwise is a UsageError unless `overwrite`: it may hold
    the mirror's offsets or a calibration that this call does not know, and replacing it would lose them."""
    info = _info(path)
    file = path / INFO
    features = [STATE, *([ACTION] if ACTION in info["features"] else [])]
    for key in features:
        _names(path, info, key)
    record = units_metadata(units)
    earlier = [info["features"][key]["units"] for key in features if "units" in info["features"][key]]
    if len(earlier) == len(features) and all(existing == record for existing in earlier):
        return False
    if earlier and not overwrite:
        raise UsageError(
            f"{file} already records {_described(earlier[0], file)}; pass --overwrite to replace that record"
        )
    for key in features:
        info["features"][key]["units"] = record
    atomic_write_bytes(file, (json.dumps(info, indent=4) + "\n").encode())
    return True


def describe_units(units: LeRobotUnits) -> str:
    """`units` in words, as `joshua lerobot-units` reports them: "SO-100 body joints in range, calibrated"."""
    calibrated = ", calibrated" if units.calibration else ""
    offsets = ", with offsets" if any(units.offsets.values()) else ""
    return f"SO-100 body joints in {units.body}{calibrated}{offsets}"


def _described(record: Any, file: Path) -> str:
    """A units record found in info.json in words (`describe_units`), or that it does not read."""
    try:
        return describe_units(units_from_metadata(record, str(file)))
    except TrajectoryError:
        return "units joshua cannot read"


def _names(path: Path, info: dict[str, Any], key: str) -> list[str]:
    """The joint names of feature `key`: a non-empty list of distinct strings, as many as its `shape` says."""
    field = f"{path / INFO}: features.{key}"
    feature = info["features"].get(key)
    if not isinstance(feature, dict):
        raise TrajectoryError(f"{field} is missing or not an object; expected one with joint names")
    names = feature.get("names")
    if not isinstance(names, list) or not names or not all(isinstance(name, str) for name in names):
        raise TrajectoryError(f"{field}.names is not a non-empty list of joint names")
    if len(set(names)) != len(names):
        raise TrajectoryError(f"{field}.names names a joint twice")
    shape = feature.get("shape")
    if shape is not None and shape != [len(names)]:
        raise TrajectoryError(f"{field}.shape is {shape!r}, but it names {len(names)} joints")
    return names


def _read_parquet(file: Path, columns: list[str], optional: tuple[str, ...] = ()) -> Any:
    """The `columns` (and those of `optional` it has) of a parquet file as a pyarrow table; a missing column or
    an unreadable file is one line."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        present = pq.read_schema(file).names
        missing = [name for name in columns if name not in present]
        if missing:
            raise TrajectoryError(f"{file}: no column {', '.join(repr(name) for name in missing)}")
        return pq.read_table(file, columns=columns + [name for name in optional if name in present])
    except (pa.ArrowException, OSError) as error:
        raise TrajectoryError(f"{file}: not a readable parquet file: {error}") from None


def _episode_row(path: Path, episode: int) -> dict[str, int]:
    """The episode's row of meta/episodes: where its frames lie, each a non-negative integer."""
    files = sorted((path / EPISODES).glob("*/*.parquet"))
    if not files:
        raise TrajectoryError(f"{path}: no {EPISODES}/chunk-*/file-*.parquet")
    known: list[int] = []
    for file in files:
        for row in _read_parquet(file, list(EPISODE_COLUMNS)).to_pylist():
            for name in EPISODE_COLUMNS:
                value = row[name]
                if not isinstance(value, int) or isinstance(value, bool) or value < 0:
                    raise TrajectoryError(f"{file}: column '{name}' holds {value!r}, expected an integer >= 0")
            if row["episode_index"] == episode:
                return row
            known.append(row["episode_index"])
    if not known:
        raise TrajectoryError(f"{path / EPISODES}: lists no episode")
    raise TrajectoryError(f"{path}: no episode {episode}; the dataset has episodes 0..{max(known)} ({len(known)})")


def _data_file(path: Path, info: dict[str, Any], row: dict[str, int]) -> Path:
    """The data file of an episode row: `data_path` filled in, relative and inside the dataset (links resolved)."""
    template = info["data_path"]
    field = f"{path / INFO}: data_path {template!r}"
    used = {name for _, name, _, _ in string.Formatter().parse(template) if name is not None}
    if not used <= DATA_PATH_FIELDS:
        raise TrajectoryError(
            f"{field} uses {', '.join(sorted(used - DATA_PATH_FIELDS))}; it may use only "
            f"{', '.join(sorted(DATA_PATH_FIELDS))}"
        )
    try:
        relative = template.format(chunk_index=row["data/chunk_index"], file_index=row["data/file_index"])
    except (ValueError, KeyError, IndexError) as error:
        raise TrajectoryError(f"{field} is not a path template: {error}") from None
    file = path / relative
    if not relative or Path(relative).is_absolute() or not file.resolve().is_relative_to(path.resolve()):
        raise TrajectoryError(f"{field} leads outside the dataset folder; it must be a path inside it")
    return file


def _episode_data(
    path: Path, info: dict[str, Any], row: dict[str, int], episode: int, names: list[str]
) -> tuple[Path, dict[str, NDArray[Any]]]:
    """The episode's columns from its data file, checked: `timestamp`, `frame_index` and finite, plausible
    `observation.state` (and `action` when the file has it) rows as wide as the names."""
    import pyarrow as pa
    import pyarrow.compute as pc

    file = _data_file(path, info, row)
    if not file.is_file():
        raise TrajectoryError(f"{path}: episode {episode}'s data file {file} is missing")
    table = _read_parquet(file, ["episode_index", "timestamp", "frame_index", STATE], optional=(ACTION,))
    if not pa.types.is_integer(table.schema.field("episode_index").type):
        raise TrajectoryError(
            f"{file}: column 'episode_index' is {table.schema.field('episode_index').type}, expected integers"
        )
    table = table.filter(pc.equal(table.column("episode_index"), episode))
    if table.num_rows == 0:
        raise TrajectoryError(f"{file}: episode {episode} has no frames")
    if table.num_rows != row["length"]:
        raise TrajectoryError(f"{file}: episode {episode} has {table.num_rows} rows, {EPISODES} says {row['length']}")
    data = {
        "timestamp": _scalars(file, table, "timestamp", np.float64),
        "frame_index": _scalars(file, table, "frame_index", np.int64),
    }
    if not np.isfinite(data["timestamp"]).all():
        raise TrajectoryError(f"{file}: column 'timestamp' holds a NaN or infinite value")
    for key in (STATE, ACTION):
        if key in table.column_names:
            data[key] = _vectors(file, table, key, names, data["frame_index"])
    return file, data


def _scalars(file: Path, table: Any, name: str, dtype: type) -> NDArray[Any]:
    """A numeric column without nulls as a numpy array of `dtype`."""
    import pyarrow as pa

    column = table.column(name)
    kind = pa.types.is_integer if dtype is np.int64 else (lambda t: pa.types.is_integer(t) or pa.types.is_floating(t))
    if not kind(column.type) or column.null_count:
        expected = "integers" if dtype is np.int64 else "numbers"
        raise TrajectoryError(
            f"{file}: column '{name}' is {column.type} with {column.null_count} nulls; expected {expected} in every row"
        )
    return np.asarray(column.to_numpy(), dtype=dtype)


def _vectors(file: Path, table: Any, key: str, names: list[str], frames: NDArray[np.int64]) -> NDArray[np.float64]:
    """Column `key`: one list of len(names) finite numbers per row, each within its feature's plausible bound
    (`frames`: the rows' frame indices, for messages)."""
    import pyarrow as pa

    column = table.column(key).combine_chunks()
    kind = column.type
    listed = pa.types.is_list(kind) or pa.types.is_large_list(kind) or pa.types.is_fixed_size_list(kind)
    if not listed or not (pa.types.is_floating(kind.value_type) or pa.types.is_integer(kind.value_type)):
        raise TrajectoryError(f"{file}: column '{key}' is {kind}; expected a list of numbers per row")
    if column.null_count or column.flatten().null_count:
        raise TrajectoryError(f"{file}: column '{key}' has an empty (null) row or value")
    widths = np.unique(column.value_lengths().to_numpy())
    if len(widths) != 1:
        raise TrajectoryError(f"{file}: column '{key}' has rows of different widths ({', '.join(map(str, widths))})")
    if widths[0] != len(names):
        raise TrajectoryError(
            f"{file}: column '{key}' is {widths[0]} wide, but {INFO} features.{key}.names has {len(names)} joints"
        )
    values = np.asarray(column.flatten().to_numpy(), dtype=np.float64).reshape(-1, len(names))
    for i, name in enumerate(names):
        bound = plausible_bound(name)
        bad = np.flatnonzero(~(np.abs(values[:, i]) <= bound))  # NaN compares false: caught too
        if bad.size:
            raise TrajectoryError(
                f"{file}: column '{key}' joint '{name}' has {values[bad[0], i]:g} at frame {frames[bad[0]]}: "
                f"not a finite value within ±{bound:g}"
            )
    return values
