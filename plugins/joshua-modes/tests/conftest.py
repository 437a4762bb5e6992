"""Fixtures for joshua-modes: the installed `joshua` script and trajectory files (Xvfb is in the root conftest).

Plain helpers live in modes_testing.py (a unique name, so it cannot clash with another plugin's tests).
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from modes_testing import JOSHUA_SCRIPT, headless_env  # noqa: E402


@pytest.fixture
def run_joshua(tmp_path: Path) -> Callable[..., subprocess.CompletedProcess[str]]:
    """Run `joshua ARGS` in a temp dir with no display (unless `env` gives one)."""

    def run(*args: str, env: dict[str, str] | None = None, timeout: float = 120) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [str(JOSHUA_SCRIPT), *args],
            cwd=tmp_path,
            env=env or headless_env(),
            capture_output=True,
            text=True,
            timeout=timeout,
        )

    return run


@pytest.fixture
def write_csv(tmp_path: Path) -> Callable[..., Path]:
    """Write a trajectory file from lines (a header and rows); returns its path."""

    def write(lines: list[str], name: str = "motion.csv") -> Path:
        path = tmp_path / name
        path.write_text("".join(f"{line}\n" for line in lines))
        return path

    return write
