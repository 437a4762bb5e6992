"""Signals as the run sees them: `signals_deferred` lets a short step finish, then hands the signal on."""

from __future__ import annotations

import signal

import pytest

from joshua_core.interrupts import signals_deferred, stop_requests


def test_a_deferred_signal_reaches_the_handler_in_place_when_the_block_ends() -> None:
    steps = []
    with pytest.raises(KeyboardInterrupt):
        with signals_deferred():
            signal.raise_signal(signal.SIGINT)
            steps.append("finished after the signal")
        steps.append("never: the interrupt comes as the block ends")
    assert steps == ["finished after the signal"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # the handler before it is back

    with stop_requests() as request, signals_deferred():  # under a trainer's handler it is a stop request
        signal.raise_signal(signal.SIGTERM)
        assert not request.requested
    assert request.signum == signal.SIGTERM
