"""Signals as the run sees them: `signals_deferred` lets a short step finish, then hands the signal on."""

from __future__ import annotations

import signal

import pytest

from joshua_core.interrupts import Interrupted, Terminated, signals_deferred, stop_requests


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


def test_held_signals_interrupt_only_the_parts_that_may_be_dropped() -> None:
    """Inside `signals_deferred`, `interruptible()` lets a signal interrupt at once; one that came while held
    interrupts on entering the next such part, or is taken by whoever finishes first, and then is not handed on."""
    steps = []
    with stop_requests() as handed_on, signals_deferred() as held:  # what the block hands on is only recorded
        with pytest.raises(Interrupted) as at_once, held.interruptible():
            signal.raise_signal(signal.SIGINT)
            steps.append("never: a rollout is dropped")
        assert at_once.value.exit_code == 130
        signal.raise_signal(signal.SIGTERM)
        steps.append("written whole")
        with pytest.raises(Terminated), held.interruptible():
            steps.append("never: the held signal comes on entering")
        signal.raise_signal(signal.SIGINT)
        assert isinstance(held.take(), Interrupted) and held.take() is None
    assert steps == ["written whole"] and not handed_on.requested
