"""`fit_of`: the joshua sysid fit a model is or includes, found through the MJCF includes, as `joshua checklist`
reports it; a damaged report is one line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from joshua_core.errors import UsageError
from joshua_sysid import fit_of

REPORT = {"model": "so_arm100.xml", "recordings": [], "fit": {"at_bounds": [], "poorly_tracked": []}}


def scene(folder: Path, arm: str) -> Path:
    """A scene in `folder` that includes `arm` from a subfolder fit/, as a trained scene includes a calibrated arm."""
    (folder / "fit").mkdir()
    (folder / "fit" / arm).write_text("<mujoco/>")
    path = folder / "scene.xml"
    path.write_text(f'<mujoco><include file="fit/{arm}"/></mujoco>')
    return path


def test_a_scene_that_includes_a_calibrated_arm_holds_its_fit(tmp_path: Path) -> None:
    path = scene(tmp_path, "so_arm100_calibrated.xml")
    (tmp_path / "fit" / "report.json").write_text(json.dumps(REPORT))
    fit = fit_of(path)
    assert fit is not None and fit.model == (tmp_path / "fit" / "so_arm100_calibrated.xml").resolve()
    assert fit.report == REPORT


def test_a_model_without_a_fit_has_none(tmp_path: Path) -> None:
    assert fit_of(scene(tmp_path, "so_arm100.xml")) is None
    assert fit_of(tmp_path / "missing.xml") is None


@pytest.mark.parametrize(
    ("text", "reason"), [("{not json", "not valid JSON"), ("[" * 100_000 + "]" * 100_000, "nested too deeply")]
)
def test_a_damaged_report_is_one_line(tmp_path: Path, text: str, reason: str) -> None:
    path = scene(tmp_path, "so_arm100_calibrated.xml")
    (tmp_path / "fit" / "report.json").write_text(text)
    with pytest.raises(UsageError, match=f"report.json: cannot read the sysid report: {reason}"):
        fit_of(path)
