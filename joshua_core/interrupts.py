"""Ctrl-C and SIGTERM as exceptions that unwind cleanly, and a way for a trainer to finish its step first.

The CLI turns SIGTERM into `Terminated` (a KeyboardInterrupt, so every `finally` and cleanup that runs on
Ctrl-C runs on SIGTERM too) and exits 128 + the signal's number (130 for SIGINT, 143 for SIGTERM),
printing one line, no traceback. A trainer wraps its loop in `stop_requests()`: the first signal only
asks it to stop, so it can save a checkpoint at a consistent point; a second one interrupts at once. A
step that must not be cut in two (a video frame encoded but not yet written) runs in `signals_deferred()`;
work that keeps what it made so far defers signals throughout and lets them interrupt only its droppable
parts (`HeldSignals.interruptible`: a rollout, not the writing of what was kept).
"""

from __future__ import annotations

import shlex
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType

from joshua_core.errors import JoshuaError

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """The run was stopped by a signal; the CLI exits with `exit_code` (128 + the signal's number)."""

    def __init__(self, signum: int = signal.SIGINT) -> None:
        super().__init__(signal.Signals(signum).name)
        self.exit_code = 128 + signum


class Terminated(Interrupted):
    """SIGTERM, raised where the process is, like Ctrl-C's KeyboardInterrupt."""

    def __init__(self) -> None:
        super().__init__(signal.SIGTERM)


def exit_code(error: KeyboardInterrupt) -> int:
    """128 + the signal that stopped the run (130 for a plain Ctrl-C)."""
    return error.exit_code if isinstance(error, Interrupted) else 128 + signal.SIGINT


def reported(job: Callable[[], int]) -> int:
    """Run `job` the way the `joshua` command runs everything: SIGTERM as `Terminated`, a `JoshuaError` as
    one line on stderr and its exit status (2 for user errors), a signal as one line and 128 + its number;
    never a traceback for either."""
    install_sigterm_handler()
    try:
        return job()
    except JoshuaError as error:
        print(f"joshua: error: {error}", file=sys.stderr)
        return error.exit_code
    except KeyboardInterrupt as interrupt:
        print("joshua: interrupted", file=sys.stderr)
        return exit_code(interrupt)


def _raise_terminated(signum: int, frame: FrameType | None) -> None:
    raise Terminated()


def install_sigterm_handler() -> None:
    """Make SIGTERM raise `Terminated` in the main thread (elsewhere signals cannot be handled)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _raise_terminated)


class StopRequest:
    """Which signal asked the run to stop, if any."""

    def __init__(self) -> None:
        self.signum: int | None = None

    @property
    def requested(self) -> bool:
        return self.signum is not None

    def handle(self, signum: int, frame: FrameType | None) -> None:
        """The first signal is recorded; a second one of either kind interrupts at once."""
        if self.signum is not None:
            raise _interruption(signum)
        self.signum = signum
        print(f"\njoshua: {signal.Signals(signum).name}: stopping after this step (again to stop now)", file=sys.stderr)

    def interrupted(self) -> Interrupted:
        """The exception to raise once the run has saved what it could."""
        assert self.signum is not None
        return _interruption(self.signum)


def _interruption(signum: int) -> Interrupted:
    """The exception signal `signum` stands for: `Terminated` for SIGTERM, `Interrupted` (a Ctrl-C) otherwise."""
    return Terminated() if signum == signal.SIGTERM else Interrupted(signum)


@contextmanager
def _handled_by(handler: Callable[[int, FrameType | None], None]) -> Iterator[None]:
    """Inside the block `handler` takes SIGINT and SIGTERM; the handlers in place before come back after it.
    Outside the main thread nothing is installed (signals are only ever handled there)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {signum: signal.signal(signum, handler) for signum in SIGNALS}
    try:
        yield
    finally:
        for signum, before in previous.items():
            signal.signal(signum, before)


@contextmanager
def stop_requests() -> Iterator[StopRequest]:
    """Inside the block SIGINT and SIGTERM only set `StopRequest.signum` (the first time); the handlers
    in place before come back after it. Outside the main thread nothing is installed."""
    request = StopRequest()
    with _handled_by(request.handle):
        yield request


class HeldSignals:
    """The signals `signals_deferred` holds back, and the parts of its block where one interrupts at once."""

    def __init__(self) -> None:
        self.arrived: list[int] = []
        self._at_once = False

    def handle(self, signum: int, frame: FrameType | None) -> None:
        """Hold `signum`; inside `interruptible()`, raise it."""
        if self._at_once:
            raise _interruption(signum)
        self.arrived.append(signum)

    def take(self) -> Interrupted | None:
        """The interruption a held signal stands for, no longer held (its taker raises it once done), or None."""
        if not self.arrived:
            return None
        interruption = _interruption(self.arrived[0])
        self.arrived.clear()
        return interruption

    @contextmanager
    def interruptible(self) -> Iterator[None]:
        """Inside the block a signal interrupts at once (`Interrupted`, `Terminated`), as the CLI's handlers do, and
        one held before it does so on entering: for work that may be dropped, between steps that must not be cut."""
        if (interruption := self.take()) is not None:
            raise interruption
        self._at_once = True
        try:
            yield
        finally:
            self._at_once = False


@contextmanager
def signals_deferred() -> Iterator[HeldSignals]:
    """SIGINT and SIGTERM that arrive inside the block reach the handlers in place before it when it ends, except
    inside `HeldSignals.interruptible()` blocks and those `HeldSignals.take()` took.

    For short steps that a signal must not cut in two: an exception raised between an encoder's output and
    the muxer's write loses a packet that every later frame of the video refers to. Outside the main thread
    nothing is installed (signals are only ever handled there)."""
    held = HeldSignals()
    try:
        with _handled_by(held.handle):
            yield held
    finally:
        if held.arrived:
            signal.raise_signal(held.arrived[0])  # the handler now in place takes it, as if it had come just now


def resume_command(options: str, run_name: str) -> str:
    """The command line that continues this run: this one plus `--set <options>.resume=true` and its name."""
    added = [f"{options}.resume=true", f"{options}.run_name={run_name}"]
    argv = ["joshua", *sys.argv[1:]]
    for setting in added:
        if setting not in argv:
            argv += ["--set", setting]
    return shlex.join(argv)
