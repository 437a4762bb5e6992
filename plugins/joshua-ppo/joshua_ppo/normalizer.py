"""The observation normaliser: running mean and variance, merged across devices, and the clipped scaling."""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from joshua_ppo.collectives import ordered_sum
from joshua_ppo.settings import OBSERVATION_CLIP


class RunningStatistics(NamedTuple):
    """Running mean and variance of observations (Chan et al.'s parallel update)."""

    count: jax.Array  # type: ignore[assignment]  # a field that shadows tuple.count, which is unused
    mean: jax.Array
    variance: jax.Array


def fresh_statistics(size: int) -> RunningStatistics:
    """Statistics of no observations yet (mean 0, variance 1)."""
    return RunningStatistics(jnp.zeros((), jnp.float32), jnp.zeros(size), jnp.ones(size))


def _std(stats: RunningStatistics) -> jax.Array:
    """The scale `normalize` divides by: the standard deviation, kept above 1e-4 for observations that never
    changed yet."""
    return jnp.sqrt(stats.variance + 1e-8)


def normalize(stats: RunningStatistics, observation: jax.Array, enabled: bool) -> jax.Array:
    """Observations scaled by the running statistics and clipped (unchanged when normalisation is off)."""
    if not enabled:
        return observation
    scaled = (observation - stats.mean) / _std(stats)
    return jnp.clip(scaled, -OBSERVATION_CLIP, OBSERVATION_CLIP)


def update_statistics(stats: RunningStatistics, observations: jax.Array, axis: str) -> RunningStatistics:
    """Merge this iteration's observations (from every device along mesh `axis`) into the running statistics.

    Once the statistics hold observations, each is first clipped to OBSERVATION_CLIP standard deviations of
    its mean, where `normalize` clips anyway: a physics blow-up (an MJX arm thrown at 3000 rad/s, a cube flung
    13 m) adds at most that much to the variance instead of rescaling, once and for good, every observation
    the policy has learned to read."""
    bound = OBSERVATION_CLIP * _std(stats)  # not 0 where every observation so far was the same
    clipped = jnp.clip(observations, stats.mean - bound, stats.mean + bound)
    observations = jnp.where(stats.count > 0, clipped, observations)
    batch_count = ordered_sum(jnp.asarray(observations.shape[0], jnp.float32), axis)
    batch_mean = ordered_sum(observations.sum(axis=0), axis) / batch_count
    batch_variance = ordered_sum(jnp.square(observations - batch_mean).sum(axis=0), axis) / batch_count
    total = stats.count + batch_count
    delta = batch_mean - stats.mean
    mean = stats.mean + delta * batch_count / total
    m2 = (
        stats.variance * stats.count
        + batch_variance * batch_count
        + jnp.square(delta) * stats.count * batch_count / total
    )
    return RunningStatistics(total, mean, m2 / total)
