"""The PPO teacher's metrics.json (`training.ppo.teacher`: the run's log says how far the teacher had learned): a
file whose values are of other types is one CorruptCheckpointError naming it (exit 2), not a traceback."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from joshua_core.errors import CorruptCheckpointError
from joshua_ppo.teacher import _described


@pytest.mark.parametrize(
    ("metrics", "problem"),
    [
        ({"history": [{"step": 5, "mean_return": "abc"}]}, "the last record's 'mean_return' is a str, not a number"),
        ({"history": [{"mean_return": [1, 2]}]}, "the last record's 'mean_return' is a list, not a number"),
        ({"history": [{"step": "many"}]}, "the last record's 'step' is a str, not a number"),
        ({"history": [{"metrics/success": {}}]}, "the last record's 'metrics/success' is a dict, not a number"),
        ({"history": "abc"}, "'history' is not a list of records (objects)"),
        ({"history": [3]}, "'history' is not a list of records (objects)"),
    ],
)
def test_metrics_of_other_types_are_one_corrupt_checkpoint_error(
    tmp_path: Path, metrics: dict[str, Any], problem: str
) -> None:
    (tmp_path / "metrics.json").write_text(json.dumps(metrics))
    with pytest.raises(CorruptCheckpointError) as caught:
        _described(tmp_path)
    assert str(caught.value) == f"{tmp_path / 'metrics.json'}: {problem}" and caught.value.exit_code == 2


def test_a_deeply_nested_metrics_file_is_one_corrupt_checkpoint_error(tmp_path: Path) -> None:
    (tmp_path / "metrics.json").write_text("[" * 100_000 + "]" * 100_000)  # json.loads recurses past Python's limit
    with pytest.raises(CorruptCheckpointError) as caught:
        _described(tmp_path)
    assert str(caught.value) == f"{tmp_path / 'metrics.json'}: cannot read the run's metrics: nested too deeply"
    assert caught.value.exit_code == 2


def test_the_last_record_describes_the_teacher(tmp_path: Path) -> None:
    record = {"step": 4096, "mean_return": 12.345, "metrics/success": 0.25}
    (tmp_path / "metrics.json").write_text(json.dumps({"history": [{"step": 0}, record]}))
    expected = f"{tmp_path} (4,096 env steps; its last iteration: mean return 12.35, success 0.250)"
    assert _described(tmp_path) == expected
