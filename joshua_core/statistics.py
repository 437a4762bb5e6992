"""95 % intervals for evaluation results: every trainer's `joshua eval` and the benches report them alike.

A trainer returns per-episode outcomes (`EpisodeResults`); `summarize` turns them into the figures a person
reads: the success rate with its Wilson score interval when the task has a `success` metric, and the mean
return with its Student t interval (always). Plain numpy and math: no SciPy in the core.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from joshua_core.interfaces import EpisodeResults

SUCCESS_METRIC = "success"  # a task metric, 1 on an episode's last step when it succeeded (pick-and-place)
SUCCESS_THRESHOLD = 0.5  # an episode succeeded when its final `success` is at least this
Z95 = 1.959963984540054  # the standard normal's 97.5 % quantile: two-sided 95 %


def wilson_interval(successes: int, trials: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a success rate: unlike the normal approximation it stays within [0, 1]
    and is honest at 0 or N successes of few trials."""
    if trials < 1 or not 0 <= successes <= trials:
        raise ValueError(f"wilson_interval needs 0 <= successes <= trials and trials >= 1, got {successes}/{trials}")
    rate = successes / trials
    denominator = 1 + z * z / trials
    centre = (rate + z * z / (2 * trials)) / denominator
    half = z * math.sqrt(rate * (1 - rate) / trials + z * z / (4 * trials * trials)) / denominator
    return max(0.0, centre - half), min(1.0, centre + half)


def student_t_quantile(df: int) -> float:
    """The 97.5 % quantile of Student's t with `df` degrees of freedom: exact for 1 and 2, else the
    Cornish-Fisher expansion around the normal quantile (Hill 1970), within 0.13 % at 3 df and 4e-6 from 10."""
    if df < 1:
        raise ValueError(f"student_t_quantile needs df >= 1, got {df}")
    if df == 1:
        return math.tan(math.pi * 0.475)
    if df == 2:
        return 0.95 / math.sqrt(2 * 0.975 * 0.025)
    z = Z95
    terms = (
        (z**3 + z) / 4,
        (5 * z**5 + 16 * z**3 + 3 * z) / 96,
        (3 * z**7 + 19 * z**5 + 17 * z**3 - 15 * z) / 384,
        (79 * z**9 + 776 * z**7 + 1482 * z**5 - 1920 * z**3 - 945 * z) / 92160,
    )
    return z + sum(term / df ** (power + 1) for power, term in enumerate(terms))


def t_interval(values: Sequence[float]) -> tuple[float, float] | None:
    """The 95 % Student t interval of the mean of `values` (None for fewer than 2: no spread to measure)."""
    samples = np.asarray(values, dtype=np.float64)
    if samples.size < 2:
        return None
    mean = float(samples.mean())
    half = student_t_quantile(samples.size - 1) * float(samples.std(ddof=1)) / math.sqrt(samples.size)
    return mean - half, mean + half


def summarize(results: EpisodeResults) -> dict[str, Any]:
    """The figures of an evaluation: episodes, mean return and length, each metric's mean final value, how many
    episodes blew up (where the trainer says), the return's 95 % t interval and, when the task has a `success`
    metric, the success rate and its Wilson interval."""
    episodes = len(results.returns)
    if episodes < 1:
        raise ValueError("no episode finished: nothing to summarize")
    summary: dict[str, Any] = {
        "episodes": episodes,
        "mean_return": float(np.mean(results.returns)),
        "mean_length": float(np.mean(results.lengths)),
    }
    summary |= {f"final_{name}": float(np.mean(values)) for name, values in results.metrics.items()}
    if len(results.failed):  # episodes whose simulation blew up: their metrics are not numbers
        summary["failed_episodes"] = int(np.sum(results.failed))
    if SUCCESS_METRIC in results.metrics:
        successes = int(np.sum(np.asarray(results.metrics[SUCCESS_METRIC]) >= SUCCESS_THRESHOLD))
        summary |= {
            "successes": successes,
            "success_rate": successes / episodes,
            "success_rate_ci95": list(wilson_interval(successes, episodes)),
            "success_rate_ci95_method": "Wilson score",
        }
    interval = t_interval(results.returns)
    summary |= {
        "return_std": float(np.std(results.returns, ddof=1)) if episodes > 1 else None,
        "mean_return_ci95": list(interval) if interval else None,
        "mean_return_ci95_method": f"Student t, {episodes - 1} degrees of freedom",
    }
    return summary


def report_lines(summary: dict[str, Any]) -> list[str]:
    """What `joshua eval` prints: a `name: value` line per scalar (the format scripts parse), then the intervals."""
    lines = [f"{name}: {value:.6g}" for name, value in summary.items() if isinstance(value, float | int)]
    if "success_rate" in summary:
        low, high = summary["success_rate_ci95"]
        lines.append(
            f"success rate {summary['success_rate']:.3f} ({summary['successes']} of {summary['episodes']} episodes), "
            f"95 % interval [{low:.3f}, {high:.3f}] ({summary['success_rate_ci95_method']})"
        )
    if summary["mean_return_ci95"] is None:
        lines.append("mean return: no interval from a single episode")
    else:
        low, high = summary["mean_return_ci95"]
        lines.append(
            f"mean return {summary['mean_return']:.4g}, 95 % interval [{low:.4g}, {high:.4g}] "
            f"({summary['mean_return_ci95_method']})"
        )
    return lines
