"""The checkpoint signing key: two runs that write their first checkpoints at once share one whole key. Created and
then written, the key could be read empty by the other run, which stopped with "shorter than 32 bytes" (two runs
started together, test_trainer.py, once on a clean clone)."""

from __future__ import annotations

from pathlib import Path

import pytest

from joshua_core.errors import UsageError
from joshua_sb3 import run_folder
from joshua_sb3.run_folder import KEY_BYTES, KEY_ENV_VAR, signing_key


def test_a_run_that_starts_while_another_makes_the_key_gets_that_whole_key(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(KEY_ENV_VAR, str(tmp_path / "checkpoint.key"))
    draw = run_folder.secrets.token_bytes
    other: list[bytes | None] = []

    def token_bytes(size: int) -> bytes:
        """This run's key is being made: the other run asks for the key now."""
        if not other:
            other.append(None)
            other.append(signing_key(create=True))
        return draw(size)

    monkeypatch.setattr(run_folder.secrets, "token_bytes", token_bytes)
    key = signing_key(create=True)
    assert key is not None and len(key) == KEY_BYTES and key == other[1]
    assert signing_key(create=False) == key  # the one on disk


def test_a_key_file_that_is_a_folder_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(KEY_ENV_VAR, str(tmp_path))
    for create in (True, False):
        with pytest.raises(UsageError, match=f"checkpoint key {tmp_path} is a folder; set {KEY_ENV_VAR}"):
            signing_key(create=create)
