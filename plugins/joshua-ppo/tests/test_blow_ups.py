"""Simulations that blow up are counted and contained: a state beyond any scene's bounds ends its episode as a
failure, and a training whose iterations are mostly blow-ups stops with one line naming the likely causes, keeping
the checkpoint written before. The scene is made to blow up: slider_unstable.xml's motors are a million times too
strong."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from distributed_worker import SLIDER_REACH, SliderTask

import joshua_mjx.plugin
import joshua_ppo.plugin
from joshua_core import builtin_plugin, hookimpl
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.options import parse_dict
from joshua_core.plugins import PluginHost, PluginInfo, Registrar
from joshua_core.run_context import RunContext
from joshua_core.tasks import MAX_SPEED, SimulationsBlewUp, nonfinite
from joshua_ppo.trainer import PpoTrainer

UNSTABLE = dataclasses.replace(
    SLIDER_REACH, name="slider_unstable", model_path=str(Path(__file__).parent / "data" / "slider_unstable.xml")
)


class UnstableTask(SliderTask):
    @hookimpl
    def joshua_register_tasks(self, registry: Registrar) -> None:
        registry.add(UNSTABLE.name, lambda: UNSTABLE, UNSTABLE.summary)


def test_a_state_beyond_the_bounds_is_a_blow_up_before_it_turns_non_finite() -> None:
    qpos = np.zeros((4, 2))
    qvel = np.array([[0.0, 1.0], [2 * MAX_SPEED, 0.0], [np.nan, 0.0], [0.0, -MAX_SPEED]])
    assert nonfinite(np, qpos, qvel).tolist() == [False, True, True, False]


@pytest.mark.slow
def test_a_training_of_blow_ups_stops_with_one_line_and_keeps_its_checkpoint(tmp_path: Path) -> None:
    host = PluginHost(
        [
            (PluginInfo("core", "joshua-core", "0", "builtin"), builtin_plugin),
            (PluginInfo("mjx", "joshua-mjx", "0", "joshua_mjx.plugin"), joshua_mjx.plugin),
            (PluginInfo("ppo", "joshua-ppo", "0", "joshua_ppo.plugin"), joshua_ppo.plugin),
            (PluginInfo("unstable", "test-unstable", "0", "test_blow_ups"), UnstableTask()),
        ]
    )
    config = TrainingConfig()
    settings = {
        "task": "slider_unstable",
        "num_envs": 16,
        "num_steps": 4,
        "minibatch_size": 64,
        "num_epochs": 1,
        "total_timesteps": 256,
        "checkpoint_dir": str(tmp_path),
        "run_name": "unstable",
        "hidden_sizes": [8],
        "ppo": {"video_interval": -1},
    }
    parse_dict(settings, config, host.options())
    with pytest.raises(SimulationsBlewUp) as stopped:
        PpoTrainer().train(config, RunContext(host, tmp_path))
    message = str(stopped.value)
    assert "\n" not in message and message.startswith("64 of the 64 episodes that ended in iteration 1 blew up")
    assert "a timestep too large for the model" in message and "randomization ranges too wide" in message
    assert (tmp_path / "unstable_step_0" / "params.msgpack").is_file()  # the untrained policy, written before
    assert json.loads((tmp_path / "unstable" / "config.json").read_text())["task"] == "slider_unstable"
