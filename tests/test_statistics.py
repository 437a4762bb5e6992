"""The statistics `joshua eval` reports: Wilson score and Student t intervals against published values, and the
summary and JSON the command writes from a trainer's per-episode results."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import pytest

from joshua_core import hookimpl
from joshua_core.evaluation import EvalCommand
from joshua_core.interfaces import EpisodeResults, Trainer
from joshua_core.plugins import PluginHost, PluginInfo
from joshua_core.statistics import student_t_quantile, summarize, t_interval, wilson_interval

# Student t 97.5 % quantiles from the standard tables (e.g. NIST/SEMATECH e-Handbook, table 1.3.6.7.2)
T_TABLE = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 9: 2.262, 15: 2.131, 30: 2.042, 100: 1.984}


@pytest.mark.parametrize(("df", "quantile"), sorted(T_TABLE.items()))
def test_student_t_quantile_matches_the_table(df: int, quantile: float) -> None:
    assert student_t_quantile(df) == pytest.approx(quantile, rel=1.5e-3)


def test_wilson_interval_matches_published_values() -> None:
    # Newcombe (1998), Statistics in Medicine 17:857, table I: 81/263 -> 0.2553..0.3662; 0/10 -> 0..0.2775
    assert wilson_interval(81, 263) == pytest.approx((0.2553, 0.3662), abs=1e-4)
    assert wilson_interval(0, 10) == pytest.approx((0.0, 0.2775), abs=1e-4)
    assert wilson_interval(10, 10) == pytest.approx((0.7225, 1.0), abs=1e-4)
    with pytest.raises(ValueError):
        wilson_interval(3, 2)


def test_t_interval_of_known_samples() -> None:
    low, high = t_interval([1.0, 2.0, 3.0, 4.0])  # mean 2.5, sd 1.291, t(3) 3.182: half-width 2.054
    assert (low + high) / 2 == pytest.approx(2.5) and (high - low) / 2 == pytest.approx(2.054, abs=5e-3)
    assert t_interval([5.0]) is None


def test_summary_reports_success_only_for_tasks_that_have_it() -> None:
    outcome = summarize(EpisodeResults([1.0, 3.0, 2.0, 6.0], [10, 10, 8, 10], {"success": [1, 0, 1, 1]}))
    assert outcome["episodes"] == 4 and outcome["successes"] == 3 and outcome["success_rate"] == 0.75
    assert outcome["success_rate_ci95"] == pytest.approx(list(wilson_interval(3, 4)))
    assert outcome["mean_return"] == 3.0 and outcome["mean_length"] == 9.5 and outcome["final_success"] == 0.75
    without = summarize(EpisodeResults([1.0, 2.0], [5, 5], {"distance": [0.1, 0.3]}))
    assert "success_rate" not in without and without["final_distance"] == pytest.approx(0.2)
    assert without["mean_return_ci95_method"] == "Student t, 1 degrees of freedom"


class FixedTrainer(Trainer):
    """Evaluates to given per-episode results, so the command's own arithmetic and output are checked."""

    def train(self, config, context):  # type: ignore[no-untyped-def]
        raise AssertionError("not called")

    def evaluate(self, run_dir, *, episodes, video_path, video_grid=1, **_):  # type: ignore[no-untyped-def]
        assert video_path is None and video_grid == 2
        return EpisodeResults([float(i) for i in range(episodes)], [3.0] * episodes, {"success": [1.0, 0.0] * 4})


class FixedPlugin:
    @hookimpl
    def joshua_register_trainers(self, registry):  # type: ignore[no-untyped-def]
        registry.add("fixed", FixedTrainer, "test")


def test_eval_prints_the_intervals_and_writes_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / "config.json").write_text(json.dumps({"trainer": "fixed"}))
    command = EvalCommand()
    parser = argparse.ArgumentParser()
    command.add_arguments(parser)
    host = PluginHost([(PluginInfo("fixed", "joshua-fixed", "0.1", "test"), FixedPlugin())])
    assert command.run(parser.parse_args([str(run_dir), "--episodes", "8", "--grid", "2", "--no-video"]), host) == 0
    printed = capsys.readouterr().out.splitlines()
    low, high = wilson_interval(4, 8)
    assert f"success rate 0.500 (4 of 8 episodes), 95 % interval [{low:.3f}, {high:.3f}] (Wilson score)" in printed
    assert "mean_return: 3.5" in printed
    assert any(line.startswith("mean return 3.5, 95 % interval [") for line in printed)
    document = json.loads((run_dir / "eval.json").read_text())
    assert document["per_episode"]["return"] == [float(i) for i in range(8)] and document["trainer"] == "fixed"
    assert document["success_rate"] == 0.5 and document["mean_return_ci95"][0] < 3.5 < document["mean_return_ci95"][1]
    half = (document["mean_return_ci95"][1] - document["mean_return_ci95"][0]) / 2
    assert half == pytest.approx(student_t_quantile(7) * math.sqrt(6.0) / math.sqrt(8))  # sd of 0..7 is sqrt(6)
    with pytest.raises(Exception, match=r"--grid must be between 1 and --episodes \(8\), got 9"):
        command.run(parser.parse_args([str(run_dir), "--episodes", "8", "--grid", "9"]), host)
