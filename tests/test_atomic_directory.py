"""joshua_core.atomic: a folder or a file appears complete or not at all."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import pytest

from joshua_core.atomic import atomic_create_bytes, atomic_directory, atomic_write_bytes, atomic_write_json, json_safe


def test_folder_appears_only_when_the_block_succeeds(tmp_path: Path) -> None:
    target = tmp_path / "step_1"
    with pytest.raises(RuntimeError), atomic_directory(target) as folder:
        (folder / "model.zip").write_bytes(b"half")
        raise RuntimeError("killed mid-write")
    assert list(tmp_path.iterdir()) == []

    with atomic_directory(target) as folder:
        (folder / "model.zip").write_bytes(b"whole")
        assert not target.exists()
    assert (target / "model.zip").read_bytes() == b"whole"


def test_the_folder_gets_the_mode_of_a_plain_mkdir(tmp_path: Path) -> None:
    previous = os.umask(0o022)
    try:
        with atomic_directory(tmp_path / "dataset"):
            pass
    finally:
        os.umask(previous)
    assert stat.S_IMODE((tmp_path / "dataset").stat().st_mode) == 0o755  # not mkdtemp's 0700


def test_existing_folder_is_replaced(tmp_path: Path) -> None:
    target = tmp_path / "step_1"
    target.mkdir()
    (target / "old.txt").write_text("old")
    with atomic_directory(target) as folder:
        (folder / "new.txt").write_text("new")
    assert [path.name for path in target.iterdir()] == ["new.txt"]
    assert [path.name for path in tmp_path.iterdir()] == ["step_1"]


def test_atomic_file_gets_the_permissions_of_a_plain_open(tmp_path: Path) -> None:
    previous = os.umask(0o027)
    try:
        atomic_write_bytes(tmp_path / "report.json", b"{}")
    finally:
        os.umask(previous)
    assert (tmp_path / "report.json").stat().st_mode & 0o777 == 0o640


def test_json_is_never_written_with_nan_or_infinity(tmp_path: Path) -> None:
    """NaN/Infinity are not JSON: writing them is refused (the old file stays); json_safe makes them null."""
    path = tmp_path / "report.json"
    atomic_write_json(path, {"ok": True})
    with pytest.raises(ValueError, match="not JSON compliant"):
        atomic_write_json(path, {"worst": float("inf")})
    assert json.loads(path.read_text()) == {"ok": True}
    atomic_write_json(path, json_safe({"rates": [1.0, float("nan")], "worst": (float("-inf"), 2)}))
    assert json.loads(path.read_text()) == {"rates": [1.0, None], "worst": [None, 2]}
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left behind


def test_create_makes_the_file_once_owner_only_and_leaves_no_temporary(tmp_path: Path) -> None:
    path = tmp_path / "keys" / "checkpoint.key"
    assert atomic_create_bytes(path, b"first") and not atomic_create_bytes(path, b"second")
    assert path.read_bytes() == b"first" and stat.S_IMODE(path.stat().st_mode) == 0o600
    assert [entry.name for entry in path.parent.iterdir()] == ["checkpoint.key"]
