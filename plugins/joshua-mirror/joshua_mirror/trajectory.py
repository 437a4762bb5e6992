"""Trajectory CSVs: `#` comment lines, a header `timestamp,<joint names>`, then one row of numbers per sample."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from joshua_core.errors import UsageError


@dataclass(frozen=True)
class Trajectory:
    """Samples of named joints: `values[k, j]` is joint `names[j]` at `times[k]` seconds (increasing)."""

    names: list[str]
    times: NDArray[np.float64]
    values: NDArray[np.float64]


def read_trajectory(path: Path) -> Trajectory:
    """Parse a trajectory CSV; bad input raises UsageError naming the file and line."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except OSError as error:
        raise UsageError(f"{path}: cannot read the trajectory: {error.strerror}") from None
    numbered = [
        (number, line)
        for number, line in enumerate(lines, start=1)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not numbered:
        raise UsageError(f"{path}: no header line 'timestamp,<joint names>'")
    header_line, header = numbered[0]
    names = [name.strip() for name in next(csv.reader([header]))]
    if names[0] != "timestamp" or len(names) < 2:
        raise UsageError(f"{path}:{header_line}: the header must be 'timestamp,<joint names>', got '{header}'")
    rows: list[list[float]] = []
    for number, line in numbered[1:]:
        cells = next(csv.reader([line]))
        if len(cells) != len(names):
            raise UsageError(f"{path}:{number}: {len(cells)} values, the header has {len(names)} columns")
        try:
            row = [float(cell) for cell in cells]
        except ValueError:
            raise UsageError(f"{path}:{number}: not a number in '{line}'") from None
        if not all(math.isfinite(value) for value in row):
            raise UsageError(f"{path}:{number}: NaN or infinite value in '{line}'")
        if rows and row[0] <= rows[-1][0]:
            raise UsageError(f"{path}:{number}: timestamp {row[0]} does not increase (previous {rows[-1][0]})")
        rows.append(row)
    if not rows:
        raise UsageError(f"{path}: no samples after the header")
    table = np.asarray(rows)
    return Trajectory(names=names[1:], times=table[:, 0], values=table[:, 1:])
