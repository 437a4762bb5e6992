"""One training process of test_distributed.py: `python distributed_worker.py '<config JSON>' OUT`.

It trains the `ppo` trainer on a test task (`slider_reach`: a point mass reaching a target, the
smallest MJX model, so that the test's processes compile in seconds) with the config given, its
run folder under the working directory, joining other processes as the config's
`ppo.distributed` or the JOSHUA_* environment variables say. It writes the parameters it ends with
to OUT/params_<process>.msgpack, and reports errors and signals as the `joshua` command does: one
line on stderr, exit status 2 or 1, or 128 + the signal's number.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import jax
from flax import serialization

import joshua_mjx.plugin
import joshua_ppo.plugin
import joshua_ppo.trainer
from joshua_core import builtin_plugin, hookimpl
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.interrupts import reported
from joshua_core.options import parse_dict
from joshua_core.plugins import PluginHost, PluginInfo, Registrar
from joshua_core.run_context import RunContext
from joshua_core.tasks.spec import TaskSpec, TermSpec

_TARGET = {"name": "target", "low": (-0.5, -0.5, 0.0), "high": (0.5, 0.5, 0.0)}
SLIDER_REACH = TaskSpec(
    name="slider_reach",
    summary="a point mass on two slide joints reaches a random target",
    model_path=str(Path(__file__).parent / "data" / "slider.xml"),
    frame_skip=2,
    episode_length=10,
    commands={"target": 3},
    observations=(
        TermSpec("qpos"),
        TermSpec("qvel"),
        TermSpec("site_to_command", params={"site": "tip", "name": "target"}, name="offset"),
    ),
    rewards=(TermSpec("site_command_distance", -1.0, {"site": "tip", "name": "target"}, name="distance"),),
    resets=(
        TermSpec("reset_joints_uniform", params={"scale": 0.3}),
        TermSpec("sample_command_uniform", params=_TARGET, name="target"),
    ),
)


class SliderTask:
    """A plugin registering `slider_reach`."""

    @hookimpl
    def joshua_register_tasks(self, registry: Registrar) -> None:
        registry.add("slider_reach", lambda: SLIDER_REACH, SLIDER_REACH.summary)


def plugins() -> PluginHost:
    """The core, joshua-mjx's backend, the ppo trainer and the test task."""
    return PluginHost(
        [
            (PluginInfo("core", "joshua-core", "0", "builtin"), builtin_plugin),
            (PluginInfo("mjx", "joshua-mjx", "0", "joshua_mjx.plugin"), joshua_mjx.plugin),
            (PluginInfo("ppo", "joshua-ppo", "0", "joshua_ppo.plugin"), joshua_ppo.plugin),
            (PluginInfo("slider", "test-slider", "0", "distributed_worker"), SliderTask()),
        ]
    )


def keep_parameters(out: Path) -> None:
    """Make the trainer's `train_ppo` write the parameters it returns to out/params_<process>.msgpack."""
    train_ppo = joshua_ppo.trainer.train_ppo

    def training(*args: Any, **kwargs: Any) -> Any:
        state, progress = train_ppo(*args, **kwargs)
        params = serialization.to_bytes(jax.device_get(state.params))
        (out / f"params_{jax.process_index()}.msgpack").write_bytes(params)
        return state, progress

    joshua_ppo.trainer.train_ppo = training


def main(config_json: str, out: str) -> int:
    host = plugins()
    config = TrainingConfig()
    parse_dict(json.loads(config_json), config, host.options())
    keep_parameters(Path(out))

    def train() -> int:
        joshua_ppo.trainer.PpoTrainer().train(config, RunContext(host, Path(config.checkpoint_dir)))
        return 0

    return reported(train)


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
