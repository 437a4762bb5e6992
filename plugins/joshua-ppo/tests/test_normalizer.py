"""The observation normaliser: exact running statistics of what it is shown, and rare blow-ups clipped out."""

from __future__ import annotations

import jax
import numpy as np

from joshua_ppo.normalizer import RunningStatistics, fresh_statistics, update_statistics
from joshua_ppo.settings import OBSERVATION_CLIP


def updated(stats: RunningStatistics, observations: np.ndarray) -> RunningStatistics:
    """`update_statistics` on one device (the axis it sums over, of size 1)."""
    merged = jax.vmap(lambda batch: update_statistics(stats, batch, "devices"), axis_name="devices")(
        observations[None].astype(np.float32)
    )
    return jax.tree.map(lambda leaf: np.asarray(leaf[0], np.float64), merged)


def test_the_statistics_are_those_of_every_observation_shown() -> None:
    rng = np.random.default_rng(0)
    first, second = rng.normal(5.0, 40.0, (500, 3)), rng.normal(-2.0, 30.0, (700, 3))
    stats = updated(updated(fresh_statistics(3), first), second)  # the first batch: far beyond mean 0, std 1
    both = np.concatenate([first, second])
    assert stats.count == 1200
    np.testing.assert_allclose(stats.mean, both.mean(axis=0), rtol=1e-4)
    np.testing.assert_allclose(stats.variance, both.var(axis=0), rtol=1e-4)


def test_a_blow_up_moves_the_statistics_no_further_than_the_clip() -> None:
    rng = np.random.default_rng(1)
    seen = rng.normal(0.0, 1.0, (10_000, 2))
    stats = updated(fresh_statistics(2), seen)
    batch = rng.normal(0.0, 1.0, (1000, 2))
    batch[7, 0] = 3000.0  # an arm joint thrown by the solver, in rad/s
    merged = updated(stats, batch)
    clipped = batch.copy()
    clipped[7, 0] = stats.mean[0] + OBSERVATION_CLIP * np.sqrt(stats.variance[0] + 1e-8)
    np.testing.assert_allclose(merged.variance, np.concatenate([seen, clipped]).var(axis=0), rtol=1e-4)
    assert merged.variance[0] < 1.2 * stats.variance[0]  # unclipped, the one sample would make it ~820


def test_an_observation_that_never_changed_can_still_change() -> None:
    """A touch sensor that read 0 throughout the first batch: its statistics catch up with the first touches
    within ten updates (clipped at 10 standard deviations of a variance of 0, they would stay at 0)."""
    stats = updated(fresh_statistics(1), np.zeros((100, 1)))
    assert stats.variance[0] == 0.0
    for _ in range(10):
        stats = updated(stats, np.full((100, 1), 40.0))
    assert stats.mean[0] > 5.0 and np.sqrt(stats.variance[0]) > 5.0
