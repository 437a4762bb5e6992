"""`joshua eval RUN`: finds the trainer that wrote a run folder; clear errors for everything else."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from joshua_core import hookimpl
from joshua_core.errors import PluginNotFoundError, UsageError
from joshua_core.evaluation import EvalCommand
from joshua_core.interfaces import PolicyFormat, Trainer
from joshua_core.plugins import PluginHost, PluginInfo


class TrainOnlyTrainer(Trainer):
    """A trainer that cannot evaluate (it keeps Trainer's default evaluate)."""

    def train(self, config, context):  # type: ignore[no-untyped-def]
        raise AssertionError("not called")


class TrainOnlyPlugin:
    @hookimpl
    def joshua_register_trainers(self, registry):  # type: ignore[no-untyped-def]
        registry.add("train_only", TrainOnlyTrainer, "test")


def run_eval(run_dir: Path, *video: str) -> int:
    command = EvalCommand()
    parser = argparse.ArgumentParser()
    command.add_arguments(parser)
    host = PluginHost([(PluginInfo("train_only", "joshua-train-only", "0.1", "test"), TrainOnlyPlugin())])
    return command.run(parser.parse_args([str(run_dir), *(video or ["--no-video"])]), host)


def write_config(run_dir: Path, document: object) -> None:
    run_dir.mkdir()
    (run_dir / "config.json").write_text(json.dumps(document))


def test_missing_folder_and_folder_without_config(tmp_path: Path) -> None:
    with pytest.raises(UsageError, match="does not exist"):
        run_eval(tmp_path / "nope")
    with pytest.raises(UsageError, match="is not a run folder: it has no config.json"):
        run_eval(tmp_path)


def test_config_without_trainer(tmp_path: Path) -> None:
    write_config(tmp_path / "run", {"task": "so_arm100_reach"})
    with pytest.raises(UsageError, match='has no "trainer" entry'):
        run_eval(tmp_path / "run")


def test_trainer_not_installed_names_the_distribution(tmp_path: Path) -> None:
    write_config(tmp_path / "run", {"trainer": "ppo"})
    with pytest.raises(PluginNotFoundError, match="pip install joshua-ppo"):
        run_eval(tmp_path / "run")


def test_trainer_without_evaluate(tmp_path: Path) -> None:
    write_config(tmp_path / "run", {"trainer": "train_only"})
    with pytest.raises(UsageError, match="trainer TrainOnlyTrainer cannot evaluate a run"):
        run_eval(tmp_path / "run")


def test_a_video_path_that_cannot_be_written_is_refused_before_the_rollout(tmp_path: Path) -> None:
    write_config(tmp_path / "run", {"trainer": "train_only"})  # evaluating it would fail later, differently
    with pytest.raises(UsageError, match=r"^--video '.*run' is a folder; give a file name$"):
        run_eval(tmp_path / "run", "--video", str(tmp_path / "run"))
    (tmp_path / "file").write_text("")
    with pytest.raises(UsageError, match=r"^--video '.*file' is a file, not a folder"):
        run_eval(tmp_path / "run", "--video", str(tmp_path / "file" / "eval.mp4"))
    assert (tmp_path / "file").read_text() == ""


def test_cli_prints_one_line(run_joshua, tmp_path: Path) -> None:
    result = run_joshua("eval", str(tmp_path))
    assert result.returncode == 2
    assert (
        result.stderr.strip()
        == f"joshua: error: '{tmp_path}' is not a run folder: it has no config.json (training runs write one)"
    )


def test_cli_a_deeply_nested_config_is_one_line(run_joshua, tmp_path: Path) -> None:
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / "config.json").write_text("[" * 100_000 + "]" * 100_000)  # json.loads recurses past Python's limit
    result = run_joshua("eval", str(run_dir))
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr[-2000:]
    assert result.stderr == f"joshua: error: {run_dir}/config.json: cannot read the run's config: nested too deeply\n"


class NeverFormat(PolicyFormat):
    """A policy format that accepts no folder, with one option of its own."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("--never-python", type=Path, help="the format's own option")

    def accepts(self, path: Path) -> bool:
        return False

    def evaluate(self, path, args, **kwargs):  # type: ignore[no-untyped-def]
        raise AssertionError("not called")


class NeverFormatPlugin:
    @hookimpl
    def joshua_register_policy_formats(self, registry):  # type: ignore[no-untyped-def]
        registry.add("never", f"{__name__}:NeverFormat", "test")


def test_a_policy_formats_option_for_a_joshua_run_is_refused_not_ignored(tmp_path: Path) -> None:
    write_config(tmp_path / "run", {"trainer": "train_only"})
    command = EvalCommand()
    parser = argparse.ArgumentParser()
    command.add_arguments(parser)
    host = PluginHost(
        [
            (PluginInfo("train_only", "joshua-train-only", "0.1", "test"), TrainOnlyPlugin()),
            (PluginInfo("never", "joshua-never", "0.1", "test"), NeverFormatPlugin()),
        ]
    )
    command.add_plugin_arguments(parser, host)
    args = parser.parse_args([str(tmp_path / "run"), "--no-video", "--never-python", "/usr/bin/python3"])
    with pytest.raises(UsageError, match="--never-python applies to never policy folders; .* is a JOSHUA run folder"):
        command.run(args, host)
    # without the option the run goes on to its trainer (which here cannot evaluate)
    with pytest.raises(UsageError, match="trainer TrainOnlyTrainer cannot evaluate a run"):
        command.run(parser.parse_args([str(tmp_path / "run"), "--no-video"]), host)
