"""What bench/mjx_time_to_target.py reports: the metrics it compares, its curve (PNG) and its summary lines."""

from __future__ import annotations

import io
from typing import Any

import numpy as np

from joshua_core.statistics import SUCCESS_METRIC
from joshua_core.tasks import METRIC_PREFIX

# Per metric: the training metric compared with the target while training, and the evaluation's value and interval.
METRICS = {
    "return": ("mean_return", "mean_return", "mean_return_ci95"),
    "success": (METRIC_PREFIX + SUCCESS_METRIC, "success_rate", "success_rate_ci95"),
}


def plot_curve(snapshots: list[dict[str, Any]], metric: str, target: float, title: str) -> bytes:
    """PNG of the snapshots' deterministic value of `metric` and its 95 % interval against training wall time."""
    return plot_curves({f"deterministic {metric}": snapshots}, metric, target, title)


def plot_curves(runs: dict[str, list[dict[str, Any]]], metric: str, target: float, title: str) -> bytes:
    """PNG of several runs' snapshots (label: snapshots), each as `plot_curve` draws one: every seed of a
    preset in one picture, so that none is left out of the comparison."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot

    _, value_key, interval_key = METRICS[metric]
    figure, axis = pyplot.subplots(figsize=(7, 3.5), layout="constrained")
    colours = pyplot.get_cmap("tab10" if len(runs) <= 10 else "tab20").colors  # a colour per run, up to 20
    for index, (label, snapshots) in enumerate(runs.items()):
        wall = [entry["wall"] for entry in snapshots]
        values = [entry[value_key] for entry in snapshots]
        (line,) = axis.plot(wall, values, marker=".", label=label, color=colours[index % len(colours)])
        bands = [entry[interval_key] or [np.nan, np.nan] for entry in snapshots]
        alpha = 0.25 if len(runs) == 1 else 0.12
        axis.fill_between(wall, [b[0] for b in bands], [b[1] for b in bands], alpha=alpha, color=line.get_color())
    axis.fill_between([], [], [], alpha=0.25, color="grey", label="95 % interval")
    axis.axhline(target, color="grey", linestyle="--", label=f"target {target:g}")
    axis.set_xlabel("training wall time, compile included (s)")
    axis.set_ylabel(metric)
    axis.grid(alpha=0.3)
    axis.legend(fontsize=8)
    figure.suptitle(title)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=100)
    pyplot.close(figure)
    return buffer.getvalue()


def summary_lines(outcome: dict[str, Any], metric: str, target: float) -> list[str]:
    """The few lines the bench prints: time to target, throughput against raw physics, the last snapshot."""
    _, value_key, interval_key = METRICS[metric]
    reached = outcome.get("reached_target_at_seconds")
    last = outcome["snapshots"][-1] if outcome.get("snapshots") else None
    if reached is not None:
        without = outcome["reached_target_without_compile_seconds"]
        first = f"{metric} >= {target:g} after {reached:.1f} s ({without:.1f} s without compile), "
        first += f"{outcome['reached_target_at_steps']:,} env steps"
    else:
        first = f"{metric} >= {target:g} not reached in {outcome['wall_seconds']:.1f} s "
        first += f"({outcome['env_steps']:,} env steps)"
    lines = [
        f"{outcome['preset']}: {first}; compile {outcome['compile_seconds']:.1f} s",
        f"training {outcome['train_steps_per_second']:,.0f} env steps/s x frame_skip {outcome['frame_skip']} = "
        f"{outcome['fraction_of_raw_physics']:.0%} of raw MJX physics ({outcome['raw_physics_steps_per_second']:,.0f}"
        f" steps/s) on {outcome['devices']} device(s); the environment alone, under random actions, "
        f"{outcome['environment_steps_per_second']:,.0f} env steps/s (training reaches "
        f"{outcome['train_steps_per_second'] / outcome['environment_steps_per_second']:.0%} of it)",
    ]
    if last is not None:
        low, high = last[interval_key] or (float("nan"), float("nan"))
        lines.append(
            f"last snapshot ({last['wall']:.1f} s): {metric} {last[value_key]:.4g} [{low:.4g}, {high:.4g}] (95 %, "
            f"{last['episodes']} deterministic episodes), mean return {last['mean_return']:.4g}"
        )
    return lines


def normaliser_line(layout: tuple[tuple[str, int], ...], variance: np.ndarray) -> str:
    """The observation normaliser's standard deviation per observation term (the largest of its entries): a term
    whose scale jumps between snapshots (contact-force or velocity spikes) shows here."""
    widths = [width for _, width in layout]
    stds = np.split(np.sqrt(np.asarray(variance)), np.cumsum(widths)[:-1])
    return "  normaliser std: " + "  ".join(
        f"{name} {std.max():.3g}" for (name, _), std in zip(layout, stds, strict=True)
    )
