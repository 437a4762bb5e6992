"""Training curves: one PNG panel per series that has data, written atomically."""

from __future__ import annotations

from pathlib import Path

import matplotlib.image

from joshua_core.curves import write_training_curves


def test_one_panel_per_series_with_data(tmp_path: Path) -> None:
    history = [{"step": 100 * i, "return": float(i * i), "distance": 1.0 / (i + 1)} for i in range(20)]
    one = write_training_curves(history, tmp_path / "one.png", title="t", series=["return", "not logged"])
    two = write_training_curves(history, tmp_path / "two.png", title="t", series=["return", "distance"])
    assert one is not None and two is not None
    assert matplotlib.image.imread(two).shape[0] > 1.5 * matplotlib.image.imread(one).shape[0]
    assert sorted(path.name for path in tmp_path.iterdir()) == ["one.png", "two.png"]  # no temporary left


def test_nothing_to_plot_writes_nothing(tmp_path: Path) -> None:
    assert write_training_curves([{"step": 0}], tmp_path / "c.png", title="t", series=["return"]) is None
    assert not (tmp_path / "c.png").exists()
