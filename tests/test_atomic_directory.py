"""atomic_directory: a folder appears complete or not at all."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from joshua_core.atomic import atomic_directory, atomic_write_bytes


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
