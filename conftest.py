"""Settings for every test run, core and plugins alike."""

from __future__ import annotations

import signal

import pytest


def pytest_configure(config: pytest.Config) -> None:
    """Let the `joshua` processes the tests start be stopped with Ctrl-C (SIGINT), as at a terminal.

    A job started in the background by a non-interactive shell (as CI runners do) inherits SIGINT ignored,
    and passes that on to every child; Python then installs no KeyboardInterrupt handler and the tests'
    SIGINT would be lost. Handling SIGINT here makes the children start with the default again.
    """
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
