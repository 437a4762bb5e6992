"""Fixtures of joshua-sb3's tests."""

import pytest
from stable_baselines3.common.logger import Logger


@pytest.fixture
def silent_logger() -> Logger:
    """A logger with no outputs for models the tests train directly: without one, a fresh model's learn() makes an
    empty SB3-<date> folder in the system's temp folder, which nothing removes (the trainer sets its own)."""
    return Logger(None, [])
