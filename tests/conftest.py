"""Shared fixtures: run the installed `joshua` script the way a user would.

Plain helpers live beside the tests (e.g. joshua_sample_plugin.py, a third-party plugin made for them).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

REPO_ROOT = Path(__file__).resolve().parents[1]
JOSHUA_SCRIPT = Path(sys.executable).parent / "joshua"


@pytest.fixture
def run_joshua(tmp_path: Path) -> Callable[..., subprocess.CompletedProcess[str]]:
    """Run `joshua ARGS` in a subprocess (cwd defaults to a temp dir); returns the completed process."""

    def run(*args: str, cwd: Path | None = None, env: dict[str, str] | None = None, timeout: float = 300):
        return subprocess.run(
            [str(JOSHUA_SCRIPT), *args],
            cwd=cwd or tmp_path,
            env={**os.environ, **(env or {})},
            capture_output=True,
            text=True,
            timeout=timeout,
        )

    return run
