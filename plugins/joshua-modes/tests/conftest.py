"""Fixtures for joshua-modes: the installed `joshua` script, trajectory files, a real Xvfb.

Plain helpers live in modes_testing.py (a unique name, so it cannot clash with another plugin's tests).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
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


def _free_display_number() -> int:
    for number in range(90, 200):
        if not Path(f"/tmp/.X{number}-lock").exists() and not Path(f"/tmp/.X11-unix/X{number}").exists():
            return number
    raise RuntimeError("no free X display number between :90 and :199")


@pytest.fixture(scope="module")
def xvfb() -> Iterator[str]:
    """A running Xvfb (1024x768, 24 bit); yields its DISPLAY. setup.sh --dev installs it, so it must exist."""
    executable = shutil.which("Xvfb")
    assert executable, "Xvfb is not installed; ./setup.sh --dev installs it (Debian package xvfb)"
    number = _free_display_number()
    server = subprocess.Popen(
        [executable, f":{number}", "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    socket = Path(f"/tmp/.X11-unix/X{number}")
    deadline = time.monotonic() + 20
    while not socket.exists():
        assert server.poll() is None, f"Xvfb :{number} exited: {server.stderr.read().decode() if server.stderr else ''}"
        assert time.monotonic() < deadline, f"Xvfb :{number} did not start within 20 s"
        time.sleep(0.05)
    try:
        yield f":{number}"
    finally:
        server.terminate()
        server.wait(10)
