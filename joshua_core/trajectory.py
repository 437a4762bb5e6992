"""Trajectory CSV files: `#` comments, a header with `timestamp` and joint columns, one row per sample.

Columns are matched to the model's joints by name (any order, a subset allowed). A column `<joint>.target`
holds the command sent to that joint (e.g. the position target a real arm was given), beside its measured
position. Errors that make the file unreadable raise TrajectoryError with `file:line:`; values that are
readable but wrong (NaN, timestamps going back, joints out of range) are left to `joshua_modes.validation`.

Consumers load a `trajectory_path` through `joshua_core.trajectory_sources.load_trajectory`, which reads a CSV
here and hands anything else (a LeRobot dataset folder) to the `TrajectoryReader` a plugin registers.
"""

from __future__ import annotations

import csv
import difflib
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from joshua_core.atomic import atomic_write_bytes
from joshua_core.errors import UsageError

TIME_COLUMN = "timestamp"
TARGET_SUFFIX = ".target"  # `<joint>.target`: the command sent to <joint>
# Largest magnitude a finite timestamp (s) or joint position (rad, m) may have: beyond it a value is a
# corrupt file, and differences of such values overflow (1e308 - -1e308 is inf). NaN and inf are read
# and left to validation, which reports and skips their rows.
MAX_MAGNITUDE = 1e9


class TrajectoryError(UsageError):
    """A trajectory file cannot be read; the message starts with `file:line:`."""


@dataclass(frozen=True)
class Trajectory:
    """The rows of a trajectory file; `lines[i]` is the file line (1-based) of row i, for messages."""

    path: Path
    joint_names: tuple[str, ...]
    timestamps: NDArray[np.float64]  # (rows,)
    positions: NDArray[np.float64]  # (rows, joints), in the order of joint_names
    lines: NDArray[np.int64]  # (rows,)
    # (rows, joints) commands in the order of joint_names, NaN for a joint without a target column;
    # None when the source has no targets at all
    targets: NDArray[np.float64] | None = None

    @property
    def rows(self) -> int:
        return len(self.timestamps)

    def require_playable(self) -> None:
        """Raise TrajectoryError at the first row with a NaN/inf value or a timestamp that does not increase.

        For consumers that stream the samples as they are (e.g. publishing them); the replay modes report
        every problem instead, through `joshua_modes.validation`.
        """
        finite = np.isfinite(self.timestamps) & np.isfinite(self.positions).all(axis=1)
        if self.targets is not None:  # a joint without a command is NaN throughout: only commanded joints count
            commanded = ~np.isnan(self.targets).all(axis=0)
            finite &= np.isfinite(self.targets[:, commanded]).all(axis=1)
        increasing = np.concatenate(([True], np.diff(self.timestamps) > 0))
        bad = np.flatnonzero(~(finite & increasing))
        if bad.size:
            row = bad[0]
            problem = (
                "NaN or infinite value"
                if not finite[row]
                else f"timestamp {self.timestamps[row]:g} does not increase (previous {self.timestamps[row - 1]:g})"
            )
            raise TrajectoryError(f"{self.path}:{self.lines[row]}: {problem}")


def read_trajectory(path: str | Path, known_joints: Sequence[str] | None = None) -> Trajectory:
    """Read a trajectory CSV. With `known_joints`, a column naming another joint is an error listing them.

    This is the one reader of recordings: the replay modes, `mirror-replay` and `joshua sysid` all load them here.
    """
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise TrajectoryError(f"{file}: trajectory file not found") from None
    except (OSError, UnicodeDecodeError) as error:
        raise TrajectoryError(f"{file}: cannot read the trajectory: {error}") from None
    rows = [
        (number, line)
        for number, line in enumerate(text.splitlines(), start=1)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not rows:
        last = len(text.splitlines())
        raise TrajectoryError(
            f"{file}:{max(last, 1)}: no header line: the file is empty or has only comments; expected a header "
            f"such as '{TIME_COLUMN},joint_1,joint_2' and one row per sample"
        )
    header_line, header_text = rows[0]
    columns = [name.strip() for name in next(csv.reader([header_text]))]
    joints, targets = _joint_columns(file, header_line, columns, known_joints)
    if len(rows) == 1:
        raise TrajectoryError(f"{file}:{header_line}: the header is not followed by any data row")
    time_index = columns.index(TIME_COLUMN)
    joint_indices = [columns.index(name) for name in joints]
    values = np.empty((len(rows) - 1, len(columns)), dtype=np.float64)
    lines = np.empty(len(rows) - 1, dtype=np.int64)
    for row, (number, line) in enumerate(rows[1:]):
        fields = next(csv.reader([line]))
        if len(fields) != len(columns):
            raise TrajectoryError(
                f"{file}:{number}: row has {len(fields)} values, the header (line {header_line}) has "
                f"{len(columns)} columns: {', '.join(columns)}"
            )
        for column, field in enumerate(fields):
            try:
                value = float(field)
            except ValueError:
                raise TrajectoryError(
                    f"{file}:{number}: column '{columns[column]}' has '{field.strip()}', which is not a number"
                ) from None
            if abs(value) > MAX_MAGNITUDE and math.isfinite(value):
                raise TrajectoryError(
                    f"{file}:{number}: column '{columns[column]}' has {value:g}, beyond ±{MAX_MAGNITUDE:g}: "
                    "not a plausible time or joint position"
                )
            values[row, column] = value
        lines[row] = number
    target_values = None
    if targets:
        target_values = np.full((len(lines), len(joints)), np.nan)
        for name in targets:
            target_values[:, joints.index(name)] = values[:, columns.index(name + TARGET_SUFFIX)]
    return Trajectory(file, tuple(joints), values[:, time_index], values[:, joint_indices], lines, target_values)


def _joint_columns(
    file: Path, line: int, columns: list[str], known_joints: Sequence[str] | None
) -> tuple[list[str], list[str]]:
    """The joint columns of the header in file order, and the joints with a target column, after checking
    the header's names."""
    where = f"{file}:{line}"
    if TIME_COLUMN not in columns:
        close = difflib.get_close_matches(TIME_COLUMN, columns, n=1, cutoff=0.5)
        hint = f" ('{close[0]}' is close; rename it)" if close else ""
        raise TrajectoryError(
            f"{where}: the header has no '{TIME_COLUMN}' column{hint}; columns: {', '.join(columns) or 'none'}"
        )
    seen: set[str] = set()
    for name in columns:
        if not name:
            raise TrajectoryError(f"{where}: the header has an empty column name")
        if name in seen:
            raise TrajectoryError(f"{where}: column '{name}' appears twice in the header")
        seen.add(name)
    joints = [name for name in columns if name != TIME_COLUMN and not name.endswith(TARGET_SUFFIX)]
    targets = [name.removesuffix(TARGET_SUFFIX) for name in columns if name.endswith(TARGET_SUFFIX)]
    orphans = [name for name in targets if name not in joints]
    if orphans:
        raise TrajectoryError(
            f"{where}: target column(s) {', '.join(name + TARGET_SUFFIX for name in orphans)} without the "
            f"joint's own column; a '<joint>{TARGET_SUFFIX}' column goes beside a '<joint>' column"
        )
    if not joints:
        raise TrajectoryError(f"{where}: the header names no joint column besides '{TIME_COLUMN}'")
    if known_joints is not None:
        unknown = [name for name in joints if name not in known_joints]
        if unknown:
            hints = []
            for name in unknown:
                close = difflib.get_close_matches(name, known_joints, n=2)
                hints.append(f"'{name}'" + (f" (did you mean: {', '.join(close)}?)" if close else ""))
            raise TrajectoryError(
                f"{where}: {'column' if len(unknown) == 1 else 'columns'} {', '.join(hints)} "
                f"{'is not a joint' if len(unknown) == 1 else 'are not joints'} of the model; "
                f"its joints: {', '.join(known_joints)}"
            )
    return joints, targets


def write_trajectory(path: Path, trajectory: Trajectory, comment: str = "") -> None:
    """Write `trajectory` as a CSV that `read_trajectory` reads back exactly (shortest round-trip floats),
    with `<joint>.target` columns when it has targets; atomically. `comment` lines go first, after '# '."""
    text = io.StringIO()
    for line in comment.splitlines():
        text.write(f"# {line}\n")
    columns = [TIME_COLUMN, *trajectory.joint_names]
    blocks = [trajectory.timestamps[:, None], trajectory.positions]
    if trajectory.targets is not None:
        with_target = [i for i in range(len(trajectory.joint_names)) if not np.isnan(trajectory.targets[:, i]).all()]
        columns += [trajectory.joint_names[i] + TARGET_SUFFIX for i in with_target]
        blocks.append(trajectory.targets[:, with_target])
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(columns)
    writer.writerows([repr(float(value)) for value in row] for row in np.hstack(blocks))
    atomic_write_bytes(Path(path), text.getvalue().encode())
