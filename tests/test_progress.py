"""The progress bar: survives the counts long jobs really produce, and writes plain lines to logs."""

from __future__ import annotations

import pytest

from joshua_core.progress import progress_bar


def test_bar_that_overshoots_its_total_still_prints_the_count(capsys: pytest.CaptureFixture[str]) -> None:
    bar = progress_bar(1000, description="train", unit="steps", initial=200)
    bar.update(1024 - 200)  # a trainer's last batch can end past the total
    bar.close()
    log = capsys.readouterr().err
    assert "\r" not in log  # not a terminal: one line per refresh, as log files and CI consoles need
    last_line = log.strip().splitlines()[-1]
    assert last_line.startswith("train: 100%") and "1024/1024 steps" in last_line
