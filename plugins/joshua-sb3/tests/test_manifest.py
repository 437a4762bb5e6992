"""A checkpoint's manifest.json that does not read (cut, not UTF-8, nested deeper than json goes) refuses the
checkpoint in one line, exit 2, as one joshua-sb3 did not write: its pickles are never loaded."""

from __future__ import annotations

from pathlib import Path

import pytest

from joshua_sb3.run_folder import MANIFEST_FILE, MODEL_FILE, UntrustedCheckpointError, verify_checkpoint


@pytest.mark.parametrize(
    ("content", "reason"),
    [(b"[" * 100_000 + b"]" * 100_000, "nested too deeply"), (b"{", "not valid JSON"), (b"\xff", "not UTF-8")],
    ids=["deep", "cut", "not-utf8"],
)
def test_a_manifest_that_does_not_read_refuses_the_checkpoint(tmp_path: Path, content: bytes, reason: str) -> None:
    (tmp_path / MODEL_FILE).write_bytes(b"a pickle never loaded")
    (tmp_path / MANIFEST_FILE).write_bytes(content)
    with pytest.raises(UntrustedCheckpointError) as refused:
        verify_checkpoint(tmp_path, [MODEL_FILE], trust=False, trust_hint="--trust-checkpoint")
    message = str(refused.value)
    assert f"{tmp_path / MANIFEST_FILE}: cannot read the checkpoint's manifest: {reason}" in message, message
    assert "\n" not in message and refused.value.exit_code == 2
