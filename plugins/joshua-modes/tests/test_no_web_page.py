"""`--web` with a mode that shows no page (OFFSCREEN, and the core's HEADLESS) is said in one line, not ignored
unsaid; the run does its work as without it."""

from __future__ import annotations

import subprocess
from collections.abc import Callable

import pytest
from modes_testing import SMALL


@pytest.mark.parametrize(
    ("mode", "args"),
    [
        ("HEADLESS", ("--set", "simulation.mode=HEADLESS")),
        ("OFFSCREEN", ("--preset", "sim_offscreen", *SMALL, "--set", "simulation.trajectory_path=")),
    ],
)
def test_web_with_a_mode_without_a_page_is_one_line(
    run_joshua: Callable[..., subprocess.CompletedProcess[str]], mode: str, args: tuple[str, ...]
) -> None:
    result = run_joshua(*args, "--set", "simulation.duration=0.1", "--web", "8080")
    assert result.returncode == 0, result.stderr
    warnings = [line for line in result.stderr.splitlines() if line.startswith("joshua: warning:")]
    assert warnings == [f"joshua: warning: {mode} mode has no web page; ignored simulation.web (8080)"]
