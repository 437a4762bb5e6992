"""Blow-ups in sb3 training, counted and contained as in the JAX trainers: every episode whose simulation blew up
is logged (`failed_episodes`: TensorBoard, metrics.json, the summary line, `joshua eval`), a stretch of training
whose episodes mostly blew up stops with one line keeping the checkpoint before it, and a policy whose parameters
turn NaN is one line too, never a torch traceback. The scene is made to blow up: a mass on slides pulled along one
of them a million times harder than gravity leaves any scene's bounds within a step, whatever the policy does."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import joshua_mujoco.plugin
import joshua_sb3.plugin
from joshua_core import builtin_plugin, hookimpl
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.interrupts import reported
from joshua_core.plugins import PluginHost, PluginInfo, Registrar
from joshua_core.run_context import RunContext
from joshua_core.statistics import summarize
from joshua_core.tasks import TaskSpec, TermSpec
from joshua_sb3.run_folder import KEY_ENV_VAR

MASS_ON_SLIDES = """<mujoco><option timestep="0.02" gravity="{pull} 0 0"/><worldbody><body name="mass">
  <joint name="x" type="slide" axis="1 0 0" damping="0.5"/><joint name="y" type="slide" axis="0 1 0" damping="0.5"/>
  <geom type="sphere" size="0.05" mass="1" contype="0" conaffinity="0"/></body></worldbody>
  <actuator><motor joint="x" ctrlrange="-1 1"/><motor joint="y" ctrlrange="-1 1"/></actuator></mujoco>"""
SLIDER = TaskSpec(
    name="slider",
    summary="a point mass on two slide joints, pulled along one and pushed by its motors",
    model_path="",  # each test writes the model, and the config names it
    frame_skip=2,
    episode_length=10,
    observations=(TermSpec("qpos"), TermSpec("qvel")),
    rewards=(TermSpec("action_l2", -0.01),),
)
ENVS = 4
BLOW_UP = -1e7  # m/s²: 4e5 m/s after the first step's 0.04 s, past the bounds (joshua_core.tasks.MAX_SPEED)


class SliderTask:
    @hookimpl
    def joshua_register_tasks(self, registry: Registrar) -> None:
        registry.add(SLIDER.name, lambda: SLIDER, SLIDER.summary)


def host() -> PluginHost:
    """The core, the mujoco backend, the sb3 trainer and the slider task."""
    return PluginHost(
        [
            (PluginInfo("core", "joshua-core", "0", "builtin"), builtin_plugin),
            (PluginInfo("mujoco", "joshua-mujoco", "0", "joshua_mujoco.plugin"), joshua_mujoco.plugin),
            (PluginInfo("sb3", "joshua-sb3", "0", "joshua_sb3.plugin"), joshua_sb3.plugin),
            (PluginInfo("slider", "test-slider", "0", "test_blow_ups"), SliderTask()),
        ]
    )


def training(root: Path, *, pull: float, steps: int, learning_rate: float = 3e-4) -> TrainingConfig:
    """PPO on ENVS sliders pulled along x at `pull` m/s², one step per rollout, for `steps` rollouts, in the run
    folder root/slider."""
    model = root / "slider.xml"
    model.parent.mkdir(parents=True, exist_ok=True)
    model.write_text(MASS_ON_SLIDES.format(pull=pull))
    config = TrainingConfig(
        trainer="sb3",
        backend="mujoco",
        task=SLIDER.name,
        model_path=str(model),
        num_envs=ENVS,
        total_timesteps=ENVS * steps,
        num_steps=1,
        num_epochs=1,
        minibatch_size=ENVS,
        learning_rate=learning_rate,
        seed=1,
    )
    config.run_name = "slider"
    config.hidden_sizes.extend([8])
    config.checkpoint_interval = ENVS * steps  # step 0 and the end
    return config


@pytest.fixture
def key(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(KEY_ENV_VAR, str(tmp_path / "checkpoint.key"))


@pytest.mark.usefixtures("key")
def test_blow_ups_are_counted_and_a_training_of_blow_ups_stops_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plugins = host()
    trainer = plugins.trainer("sb3")
    # 3 rollouts: 12 episodes end, each blown up within its first step; too few to judge the share by
    checkpoint = trainer.train(training(tmp_path / "few", pull=BLOW_UP, steps=3), RunContext(plugins, tmp_path / "few"))
    metrics = json.loads((checkpoint / "metrics.json").read_text())
    assert metrics["failed_episodes"] == 12
    assert [record["failed_episodes"] for record in metrics["history"]] == [4, 4, 4]  # one record per rollout
    assert "; 12 episodes blew up; checkpoint" in capsys.readouterr().out
    results = trainer.evaluate(
        tmp_path / "few" / "slider", episodes=3, seed=0, video_path=None, context=RunContext(plugins, tmp_path)
    )
    assert list(results.failed) == [True, True, True] and summarize(results)["failed_episodes"] == 3
    # 5 rollouts: the 16 episodes of the first four blew up, and training stops before learning from them
    stopped = reported(
        lambda: trainer.train(
            training(tmp_path / "most", pull=BLOW_UP, steps=5), RunContext(plugins, tmp_path / "most")
        )
    )
    [error] = [line for line in capsys.readouterr().err.splitlines() if line.startswith("joshua:")]
    assert stopped == 1 and error.startswith(
        "joshua: error: 16 of the 16 episodes that ended in steps 0 to 16 blew up (a state"
    )
    assert "a timestep too large for the model" in error and "randomization ranges too wide" in error
    assert sorted(path.name for path in (tmp_path / "most").iterdir()) == [
        "slider",
        "slider.xml",
        "slider_step_0",
    ]


@pytest.mark.usefixtures("key")
def test_a_policy_that_turns_nan_is_one_line_keeping_the_checkpoint_before(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plugins = host()
    config = training(tmp_path, pull=0, steps=4, learning_rate=1e30)  # Adam's first step throws every weight to 1e30
    stopped = reported(lambda: plugins.trainer("sb3").train(config, RunContext(plugins, tmp_path)))
    [error] = [line for line in capsys.readouterr().err.splitlines() if line.startswith("joshua:")]
    assert (
        stopped == 1 and error.startswith("joshua: error: training diverged at ") and "became NaN or infinite" in error
    )
    assert "Lower training.learning_rate" in error
    assert sorted(path.name for path in tmp_path.iterdir() if path.is_dir()) == ["slider", "slider_step_0"]
