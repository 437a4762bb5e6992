"""`read_json_object`, the one reader of JSON files a user may damage: whatever is wrong with the file is one
line naming it, raised as the caller's error type, never a traceback (deep nesting included)."""

from __future__ import annotations

from pathlib import Path

import pytest

from joshua_core.errors import CorruptCheckpointError, UsageError
from joshua_core.json_files import read_json_object


@pytest.mark.parametrize(
    ("content", "reason"),
    [
        (b"[" * 100_000 + b"]" * 100_000, "nested too deeply"),
        (b'{"a": ', "not valid JSON: Expecting value: line 1 column 7 (char 6)"),
        (b'{"a": 1' + b"1" * 5000 + b"}", "not valid JSON: Exceeds the limit (4300 digits)"),
        (b'{"a": "\xff"}', "not UTF-8 text (byte 7 is 0xff)"),
        (b"[1, 2]", "it holds a JSON array, not an object"),
        (b"null", "it holds a JSON null, not an object"),
    ],
    ids=["deep", "cut", "long-number", "not-utf8", "array", "null"],
)
def test_a_damaged_file_is_one_line_naming_it(tmp_path: Path, content: bytes, reason: str) -> None:
    path = tmp_path / "config.json"
    path.write_bytes(content)
    with pytest.raises(UsageError) as caught:
        read_json_object(path, "the run's config")
    assert str(caught.value).startswith(f"{path}: cannot read the run's config: {reason}"), str(caught.value)
    assert "\n" not in str(caught.value) and caught.value.exit_code == 2


def test_a_missing_file_or_a_folder_is_the_callers_error(tmp_path: Path) -> None:
    with pytest.raises(CorruptCheckpointError, match=r"metrics.json: cannot read it: No such file or directory$"):
        read_json_object(tmp_path / "metrics.json", "it", CorruptCheckpointError)
    with pytest.raises(CorruptCheckpointError, match=r": cannot read it: Is a directory$"):
        read_json_object(tmp_path, "it", CorruptCheckpointError)


def test_an_object_is_returned_as_it_is(tmp_path: Path) -> None:
    (tmp_path / "config.json").write_text('{"trainer": "ppo", "nested": [[{"a": 1}]]}', encoding="utf-8")
    assert read_json_object(tmp_path / "config.json", "it") == {"trainer": "ppo", "nested": [[{"a": 1}]]}
