"""Training curves as a PNG: what people would rather look at than read in metrics.json.

Trainers call `write_training_curves` whenever they rewrite metrics.json. Matplotlib is imported only
here, and only then: it comes with the `plots` extra of joshua-core, which the trainer plugins require.
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from pathlib import Path

from joshua_core.atomic import atomic_write_bytes

STEP_KEY = "step"


def write_training_curves(
    history: Sequence[Mapping[str, float]], path: Path, *, title: str, series: Sequence[str]
) -> Path | None:
    """Plot each named series of `history` (records with a "step" and scalar values) against the step, one
    panel each, and write the PNG atomically. Series that no record has are left out; returns None (and
    writes nothing) when none has any value."""
    panels = [(name, [(record[STEP_KEY], record[name]) for record in history if name in record]) for name in series]
    panels = [(name, points) for name, points in panels if points]
    if not panels:
        return None
    import matplotlib

    matplotlib.use("Agg")  # files only, never a window
    from matplotlib import pyplot

    figure, axes = pyplot.subplots(
        len(panels), 1, figsize=(7, 2.4 * len(panels)), sharex=True, squeeze=False, layout="constrained"
    )
    for axis, (name, points) in zip(axes[:, 0], panels, strict=True):
        steps, values = zip(*points, strict=True)
        axis.plot(steps, values, marker="." if len(points) < 50 else None)
        axis.set_ylabel(name, fontsize=8)
        axis.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("environment steps")
    figure.suptitle(title)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=100)
    pyplot.close(figure)
    atomic_write_bytes(path, buffer.getvalue())
    return path
