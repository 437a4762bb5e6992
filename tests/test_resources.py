"""Finding files named by users and presets (`resolve_data_path`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from joshua_core.errors import ModelError
from joshua_core.resources import resolve_data_path


def test_a_folder_where_a_file_is_wanted_is_named_a_folder(tmp_path: Path) -> None:
    (tmp_path / "robot").mkdir()
    with pytest.raises(ModelError, match=f"^model 'robot' is a folder \\({tmp_path / 'robot'}\\); give the path of a"):
        resolve_data_path("robot", base_dirs=(tmp_path,))
    assert resolve_data_path("robot", base_dirs=(tmp_path,), folders=True) == (tmp_path / "robot").resolve()


def test_a_missing_file_names_every_path_tried(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match=f"^trajectory file 'nowhere.csv' not found; searched:\n  {tmp_path}/nowhere"):
        resolve_data_path("nowhere.csv", base_dirs=(tmp_path,), what="trajectory")
