"""Feature statistics as LeRobot keeps them (meta/stats.json and each episode's `stats/<feature>/<stat>`)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

QUANTILES = {"q01": 0.01, "q10": 0.10, "q50": 0.50, "q90": 0.90, "q99": 0.99}
IMAGE_SAMPLE_PIXELS = 4096  # pixels per frame kept for a camera's statistics (LeRobot samples too)


def vector_stats(values: NDArray[Any]) -> dict[str, NDArray[Any]]:
    """min, max, mean, std, count and quantiles over the rows of (frames, dims) `values`, per dimension."""
    values = values.reshape(len(values), -1)
    floats = values.astype(np.float64)
    stats = {
        "min": values.min(axis=0),
        "max": values.max(axis=0),
        "mean": floats.mean(axis=0),
        "std": floats.std(axis=0),
        "count": np.array([len(values)]),
    }
    return stats | {key: np.quantile(floats, q, axis=0) for key, q in QUANTILES.items()}


def image_sample(frame: NDArray[np.uint8]) -> NDArray[np.float64]:
    """An evenly spaced sample of a (H, W, 3) frame's pixels, as (pixels, 3) values in [0, 1]."""
    pixels = frame.reshape(-1, 3)
    step = max(1, len(pixels) // IMAGE_SAMPLE_PIXELS)
    return pixels[::step].astype(np.float64) / 255.0


def image_stats(samples: list[NDArray[np.float64]], frames: int) -> dict[str, NDArray[Any]]:
    """Per-channel statistics of sampled pixels, shaped (3, 1, 1) as LeRobot's are; count is the frames."""
    stats = vector_stats(np.concatenate(samples))
    stats = {key: value.reshape(3, 1, 1) for key, value in stats.items() if key != "count"}
    return stats | {"count": np.array([frames])}


def as_json(stats: dict[str, dict[str, NDArray[Any]]]) -> dict[str, dict[str, Any]]:
    """Statistics as nested lists (meta/stats.json)."""
    return {feature: {key: value.tolist() for key, value in by_stat.items()} for feature, by_stat in stats.items()}
