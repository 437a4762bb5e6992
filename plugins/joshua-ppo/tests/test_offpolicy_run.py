"""The off-policy trainers end to end on the CPU: TD3 and SAC learn to reach on a point mass, the run folder and
checkpoints are complete, `joshua eval` rolls a run out, the exported MLP is the actor, and training resumes from
the newest checkpoint with its optimisers."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import jax
import numpy as np
import pytest
from distributed_worker import SLIDER_REACH, SliderTask
from flax.serialization import from_bytes

import joshua_mjx.plugin
import joshua_ppo.plugin
from joshua_core import builtin_plugin, hookimpl
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.options import parse_dict
from joshua_core.plugins import PluginHost, PluginInfo, Registrar
from joshua_core.run_context import RunContext
from joshua_core.runs import run_checkpoints
from joshua_ppo.envs import environment
from joshua_ppo.offpolicy_train import load_actor, offpolicy_policy
from joshua_ppo.offpolicy_trainer import OffPolicyTrainer, SacTrainer, Td3Trainer

pytestmark = pytest.mark.slow  # every test here trains

# 50 steps of 40 ms: 2 s in which a push of 1 N moves the 1 kg mass across the 1 m target square
REACH = dataclasses.replace(SLIDER_REACH, name="slider_reach_long", episode_length=50)
# 16 environments, 8 updates per step: about 8000 gradient steps in 16000 environment steps, 40 s on 2 cores
CONFIG: dict[str, Any] = {
    "framework": "MJX",
    "task": "slider_reach_long",
    "num_envs": 16,
    "num_steps": 10,
    "minibatch_size": 256,
    "total_timesteps": 16000,
    "seed": 0,
    "run_name": "reach",
    "checkpoint_interval": 8000,
    "offpolicy": {
        "actor_hidden_sizes": [64, 64],
        "critic_hidden_sizes": [64, 64],
        "replay_steps": 1000,
        "updates_per_step": 8,
        "learning_starts": 16,
        "video_interval": -1,
    },
}


class LongReach(SliderTask):
    """The slider's reaching task with episodes long enough to reach the target."""

    @hookimpl
    def joshua_register_tasks(self, registry: Registrar) -> None:
        registry.add(REACH.name, lambda: REACH, REACH.summary)


def plugins() -> PluginHost:
    return PluginHost(
        [
            (PluginInfo("core", "joshua-core", "0", "builtin"), builtin_plugin),
            (PluginInfo("mjx", "joshua-mjx", "0", "joshua_mjx.plugin"), joshua_mjx.plugin),
            (PluginInfo("ppo", "joshua-ppo", "0", "joshua_ppo.plugin"), joshua_ppo.plugin),
            (PluginInfo("reach", "test-reach", "0", "test_offpolicy_run"), LongReach()),
        ]
    )


def train(trainer: OffPolicyTrainer, root: Path, **changes: Any) -> Path:
    config = TrainingConfig()
    settings = {**CONFIG, "trainer": trainer.name, "checkpoint_dir": str(root)}
    settings["offpolicy"] = {**CONFIG["offpolicy"], **changes.pop("offpolicy", {})}
    parse_dict({**settings, **changes}, config, plugins().options())
    return trainer.train(config, RunContext(plugins(), root))


def improvement(trainer: OffPolicyTrainer, root: Path) -> tuple[float, float]:
    """The deterministic mean return of the run's untrained and trained actor over the same 16 episodes."""
    context = RunContext(plugins(), root)

    def mean_return(folder: Path) -> float:
        results = trainer.evaluate(folder, episodes=16, seed=5, video_path=None, context=context)
        assert len(results.returns) == 16
        return float(np.mean(results.returns))

    return mean_return(root / "reach_step_0"), mean_return(root / "reach")


def test_td3_learns_and_its_run_is_complete_evaluable_exportable_and_resumable(tmp_path: Path) -> None:
    """One training (the CPU's time is the suite's), then everything a run offers, in order."""
    assert train(Td3Trainer(), tmp_path) == tmp_path / "reach_step_16000"
    untrained, trained = improvement(Td3Trainer(), tmp_path)
    # measured on the CPU: about -23 untrained (the distance summed over 50 steps), -9 trained
    assert trained > untrained + 5.0, (untrained, trained)
    check_the_run_folder(tmp_path)
    check_the_exported_mlp(tmp_path)
    check_resuming(tmp_path)


def test_sac_learns(tmp_path: Path) -> None:
    train(SacTrainer(), tmp_path)
    untrained, trained = improvement(SacTrainer(), tmp_path)
    assert trained > untrained + 5.0, (untrained, trained)
    history = json.loads((tmp_path / "reach" / "metrics.json").read_text())["history"]
    assert all(np.isfinite(record["value_loss"]) and record["alpha"] > 0 for record in history[2:])


def check_the_run_folder(root: Path) -> None:
    assert [path.name for path in run_checkpoints(root, "reach")] == [
        "reach_step_0",
        "reach_step_8000",
        "reach_step_16000",
    ]
    newest = root / "reach_step_16000"
    saved = from_bytes(None, (newest / "params.msgpack").read_bytes())  # as a user loads it, as PPO's
    assert set(saved) == {"params", "normalizer"} and saved["params"]["Dense_2"]["kernel"].shape == (64, 2)
    resumable = from_bytes(None, (newest / "train_state.msgpack").read_bytes())
    assert set(resumable["learner"]) >= {"critic", "target_actor", "target_critic", "opt_state", "log_alpha"}
    config = json.loads((newest / "config.json").read_text())
    assert config["trainer"] == "td3" and config["format"] == "joshua-offpolicy-run/1"
    assert config["settings"]["updates_per_step"] == 8 and config["settings"]["n_step"] == 3
    run = root / "reach"
    assert (run / "training_curves.png").stat().st_size > 0 and any((run / "tensorboard").iterdir())


def check_the_exported_mlp(root: Path) -> None:
    """`joshua export` reads the actor as PPO's policy: the MLP's actions are the actor's deterministic ones."""
    context = RunContext(plugins(), root)
    exported = Td3Trainer().export_policy(root / "reach", context=context)
    mlp = exported.policy
    assert exported.trainer == "td3" and mlp.output == "tanh"
    config = TrainingConfig()
    parse_dict({**CONFIG, "trainer": "td3"}, config, plugins().options())
    settings = context.settings("offpolicy", config)
    env = environment(config, context, 8)
    params, normalizer = load_actor(root / "reach_step_16000", env, settings)
    state = env.reset(jax.random.PRNGKey(3))
    expected = np.asarray(offpolicy_policy(env, settings)(params, normalizer, state))
    x = np.clip((np.asarray(state.observation) - mlp.obs_mean) / mlp.obs_std, -mlp.obs_clip, mlp.obs_clip)
    for layer in mlp.layers[:-1]:
        x = np.maximum(x @ layer.weight + layer.bias, 0.0)
    actions = np.tanh(x @ mlp.layers[-1].weight + mlp.layers[-1].bias)
    np.testing.assert_allclose(actions, expected, atol=1e-5)  # float32 networks computed two ways


def check_resuming(root: Path) -> None:
    first = from_bytes(None, (root / "reach_step_16000" / "train_state.msgpack").read_bytes())
    checkpoint = train(Td3Trainer(), root, total_timesteps=16320, resume=True)
    assert checkpoint.name == "reach_step_16320"
    second = from_bytes(None, (checkpoint / "train_state.msgpack").read_bytes())
    assert (first["iteration"], second["iteration"]) == (100, 102)
    # the buffer is not saved: the resumed run collects 16 steps before it updates again, then 2 x 10 x 8 updates
    assert int(second["learner"]["updates"]) == int(first["learner"]["updates"]) + (20 - 16 + 1) * 8
    history = json.loads((checkpoint / "metrics.json").read_text())["history"]
    assert [record["step"] for record in history[-3:]] == [16000, 16160, 16320]
