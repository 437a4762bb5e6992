"""The models `joshua sysid` writes: how a calibrated model is named, the report beside it, and `fit_of`, which
finds the fit a model file is or includes (what `joshua checklist` reports about a trained run's model).

Imports nothing heavy: reading a report needs neither mujoco nor the fit.
"""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from joshua_core.json_files import read_json_object

REPORT_FILE = "report.json"
CALIBRATED_SUFFIX = "_calibrated.xml"


def calibrated_model_name(model_path: Path) -> str:
    return f"{model_path.stem}{CALIBRATED_SUFFIX}"


@dataclass(frozen=True)
class Fit:
    """A `joshua sysid` fit found in a model: the calibrated model file and its report.json (`report_document`)."""

    model: Path
    report: dict[str, Any]


def fit_of(model_path: Path) -> Fit | None:
    """The fit whose calibrated model is `model_path` or a file it includes (MJCF `<include>`, followed through
    every level), or None: a calibrated model is a `<stem>_calibrated.xml` with the fit's report.json beside it.
    A report that is not JSON is a one-line UsageError naming it."""
    seen: set[Path] = set()
    pending = [model_path.resolve()]
    while pending:
        path = pending.pop()
        if path in seen or not path.is_file():
            continue
        seen.add(path)
        report = path.parent / REPORT_FILE
        if path.name.endswith(CALIBRATED_SUFFIX) and report.is_file():
            return Fit(path, read_json_object(report, "the sysid report"))
        pending.extend(_includes(path, model_path.resolve().parent))
    return None


def _includes(path: Path, top: Path) -> list[Path]:
    """The files `path` includes, each relative to the including file or, failing that, to the top model's folder
    (MuJoCo's own rule); a file that is not XML includes nothing here (the model loader says what is wrong)."""
    if path.suffix.lower() != ".xml":
        return []
    try:
        root = ElementTree.parse(path).getroot()
    except (ElementTree.ParseError, OSError):
        return []
    found = []
    for element in root.iter("include"):
        name = element.get("file")
        if name:
            near = path.parent / name
            found.append(near if near.is_file() else top / name)
    return found
