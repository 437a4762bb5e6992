"""Progress display for long work: a tqdm bar with rate and ETA on a terminal, periodic lines otherwise."""

from __future__ import annotations

import sys
from typing import TextIO

from tqdm import tqdm

BAR_FORMAT = "{desc}: {percentage:3.0f}%|{bar:20}| {n_fmt}/{total_fmt} {unit} [{elapsed}<{remaining}, {rate_fmt}]"


def progress_bar(total: float, *, description: str, unit: str, initial: float = 0) -> tqdm:
    """A progress bar over `total` units, starting at `initial` (e.g. a resumed run: the rate counts only new
    units); when stderr is not a terminal it prints a line every 5 s."""
    interactive = sys.stderr.isatty()
    return _Bar(
        total=total,
        initial=initial,
        desc=description,
        unit=unit,
        file=sys.stderr if interactive else _Lines(sys.stderr),
        dynamic_ncols=interactive,
        mininterval=0.2 if interactive else 5.0,
        ascii=not interactive,
        bar_format=BAR_FORMAT,
    )


def status_line(text: str) -> None:
    """Print `text` as a line of its own on stderr, also while a progress bar is showing (e.g. "compiling ...")."""
    tqdm.write(text, file=sys.stderr)


class _Bar(tqdm):
    """A tqdm bar whose total grows when the work overshoots it (a trainer's last batch can end past the
    requested steps), so the last line reads 100% with the true count."""

    total: float | None  # tqdm's own attribute (tqdm ships no types); None for a bar without a total

    def update(self, n: float | None = 1) -> bool | None:
        if self.total is not None and n is not None and self.n + n > self.total:
            self.total = self.n + n
        return super().update(n)


class _Lines:
    """The stream tqdm writes to when stderr is a log, not a terminal: each refresh becomes a line of its own
    instead of overwriting the last one with a carriage return."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream

    def write(self, text: str) -> None:
        for line in text.replace("\r", "\n").split("\n"):
            if line.strip():
                self.stream.write(line.rstrip() + "\n")

    def flush(self) -> None:
        self.stream.flush()
