"""The entry point registers the three modes, lazily."""

from __future__ import annotations


def test_joshua_plugins_lists_the_three_modes(run_joshua) -> None:
    result = run_joshua("plugins")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("modes  (joshua-modes 0.1.0)"))
    assert lines[start].endswith("joshua_modes.plugin")
    registered = [line.split()[:2] for line in lines[start + 1 : start + 4]]
    assert registered == [["mode", "OFFSCREEN"], ["mode", "PASSIVE"], ["mode", "INTERACTIVE"]]
