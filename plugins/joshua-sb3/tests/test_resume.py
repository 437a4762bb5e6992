"""Resuming an sb3 run that has no checkpoint (it stopped before its first) trains it from the start, and says so
in one line rather than starting afresh without a word."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.options import options_of
from joshua_core.plugins import PluginHost
from joshua_core.run_context import RunContext
from joshua_core.runs import CONFIG_FILE, create_run
from joshua_sb3 import options_pb2
from joshua_sb3.settings import sb3_settings
from joshua_sb3.trainer import RUN_OPTIONS, TRAINER_NAME, _open_run

TASK = "so_arm100_reach"


def test_resuming_a_run_without_a_checkpoint_says_it_starts_afresh(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = TrainingConfig(task=TASK, resume=True, run_name="reach")
    settings = sb3_settings(options_of(config, options_pb2.sb3), config)
    with create_run(tmp_path, "reach", stem=TASK, options=RUN_OPTIONS) as run:  # its config written, then stopped
        saved = {"trainer": TRAINER_NAME, "algorithm": settings.algorithm, "task": TASK}
        (run.path / CONFIG_FILE).write_text(json.dumps(saved))
    capsys.readouterr()
    run, checkpoint = _open_run(config, RunContext(PluginHost([]), tmp_path), settings)
    run.close()
    assert run.path == tmp_path / "reach" and checkpoint is None
    assert capsys.readouterr().err == (
        f"joshua: warning: training.resume: run {tmp_path / 'reach'} has no checkpoint (it stopped before its "
        "first); training it from the start\n"
    )
