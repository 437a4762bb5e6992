"""tools/check_commit_msg.py passes a subject of 72 characters, fails one of 73, and reads past git's comments."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

REPO_ROOT = Path(__file__).resolve().parents[1]


def check_commit_msg() -> ModuleType:
    spec = importlib.util.spec_from_file_location("check_commit_msg", REPO_ROOT / "tools" / "check_commit_msg.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_subject_length_limit(tmp_path: Path) -> None:
    check = check_commit_msg()
    message = tmp_path / "COMMIT_EDITMSG"
    message.write_text("# Please enter the commit message\n\n" + "a" * 72 + "\n\n" + "b" * 200 + "\n")
    assert check.main([str(message)]) == 0  # the body may be as long as it likes
    message.write_text("a" * 73 + "\n")
    assert check.main([str(message)]) == 1
    assert "73 characters" in check.findings("a" * 73)[0]


def test_empty_message_fails() -> None:
    assert check_commit_msg().findings("# only a comment\n\n") == ["the commit message has no subject"]
