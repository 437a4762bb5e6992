"""The randomization curriculum (joshua_core.tasks.randomization.Curriculum) on the CPU backend: training
environments draw their events at their own strength, which follows their episodes' success; evaluation
environments draw at full strength; bad curricula fail when the task is built."""

from __future__ import annotations

import numpy as np
import pytest
from google.protobuf import text_format

from joshua_core.config import load_preset
from joshua_core.config_pb2 import TaskConfig, TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.interfaces import EnvKind, EnvSpec
from joshua_core.options import LENIENT
from joshua_core.plugins import PluginHost
from joshua_core.run_context import RunContext
from joshua_core.tasks import Curriculum

TASK = "so_arm100_pick_place"
# a metric that is 1 on every step (every episode succeeds) and one that is 0 with zero actions (every one fails)
ALWAYS = 'terms { name: "always" term: "alive" kind: METRIC } '
NEVER = 'terms { name: "never" term: "action_l2" kind: METRIC } '


def randomized(curriculum: str, extra: str = "", episode_length: int = 0) -> TaskConfig:
    """The randomized preset's task config with `curriculum` (a RandomizationCurriculum's fields) and `extra`."""
    config = TaskConfig()
    config.CopyFrom(load_preset("so_arm100_pick_place_mjx_dr", LENIENT).message.training.task_config)
    config.ClearField("randomization_curriculum")
    text_format.Merge(f"randomization_curriculum {{ {curriculum} }} {extra}", config)
    config.episode_length = episode_length
    return config


def envs(config: TaskConfig, num_envs: int = 64, *, curriculum: bool = True):
    spec = EnvSpec(TASK, num_envs, seed=3, nthread=1, task_config=config, curriculum=curriculum)
    plugins = PluginHost.discover()
    return plugins.backend("mujoco").create_envs(spec, EnvKind.NUMPY, plugins)


def mass_ratios(env) -> np.ndarray:
    cube = env.simulation.model.body("cube").id
    return env.simulation.physics.batch.expanded("body_mass")[:, cube] / env.task.defaults["body_mass"][cube]


def test_strength_zero_leaves_the_model_as_it_is_and_half_strength_draws_half_as_far() -> None:
    quiet = envs(randomized('metric: "success" start: 0'))
    simulation = quiet.simulation
    np.testing.assert_array_equal(mass_ratios(quiet), 1.0)
    assert not simulation.params["action_delay"].any()
    assert not simulation.params["obs_noise"].any()
    for name in ("geom_friction", "actuator_gainprm", "actuator_biasprm"):
        drawn = simulation.physics.batch.expanded(name)
        np.testing.assert_array_equal(drawn, np.broadcast_to(quiet.task.defaults[name], drawn.shape))
    quiet.step(np.zeros((64, quiet.task.action_size)))
    assert not quiet.simulation.params["obs_noise"].any()  # the interval events drew at strength 0 too

    half = mass_ratios(envs(randomized('metric: "success" start: 0.5')))
    full = mass_ratios(envs(randomized('metric: "success" start: 0.5'), curriculum=False))
    # the cube's mass is drawn x U(0.7, 1.3): half strength x (1 + 0.5 (u - 1)), within [0.85, 1.15]
    assert 0.85 - 1e-12 <= half.min() and half.max() <= 1.15 + 1e-12
    assert half.max() - half.min() > 0.15  # spread over the range, not stuck at one value
    assert 0.7 <= full.min() and full.max() <= 1.3 and full.max() - full.min() > 0.3


def test_half_strength_delays_half_the_actions_on_average() -> None:
    # delay x U{0, 1} at strength 0.5, rounded at random: one step of delay with probability 1/4
    delays = envs(randomized('metric: "success" start: 0.5'), num_envs=4000).simulation.params["action_delay"]
    assert set(np.unique(delays)) <= {0, 1}
    assert abs(delays.mean() - 0.25) < 0.04  # 4000 Bernoulli(1/4) draws: std 0.007


def test_strengths_rise_after_successes_and_fall_after_failures() -> None:
    env = envs(randomized('metric: "always" start: 0 step_up: 0.25', ALWAYS, episode_length=3), num_envs=8)
    action = np.zeros((8, env.task.action_size))
    seen = []
    for _ in range(5):  # five episodes of 3 steps; the metric reports the strength each one ran at
        for _ in range(3):
            _, _, _, _, info = env.step(action)
        seen.append(info["metrics"]["randomization_strength"])
    np.testing.assert_allclose(seen, np.repeat([[0.0], [0.25], [0.5], [0.75], [1.0]], 8, axis=1))
    assert 0.7 <= mass_ratios(env).min() < mass_ratios(env).max() <= 1.3  # now at full strength

    failing = envs(randomized('metric: "never" start: 1 step_down: 0.4', NEVER, episode_length=2), num_envs=8)
    for expected in (0.6, 0.2, 0.0):
        for _ in range(2):
            failing.step(np.zeros((8, failing.task.action_size)))
        np.testing.assert_allclose(failing.simulation.strength, expected, atol=1e-12)
    np.testing.assert_array_equal(mass_ratios(failing), 1.0)


def test_training_environments_follow_the_curriculum_and_evaluation_draws_at_full_strength(tmp_path) -> None:
    training = TrainingConfig()
    training.CopyFrom(load_preset("so_arm100_pick_place_mjx_dr", LENIENT).message.training)
    training.trainer, training.backend = "sb3", "mujoco"
    training.ClearField("model_path")  # the task's own model
    training.ClearField("task_config")
    training.task_config.CopyFrom(randomized('metric: "success"'))
    context = RunContext(PluginHost.discover(), tmp_path)
    learning = context.create_envs(training, EnvKind.NUMPY, num_envs=16, training_envs=True)
    evaluation = context.create_envs(training, EnvKind.NUMPY, num_envs=16)
    np.testing.assert_array_equal(learning.simulation.strength, 0.0)
    np.testing.assert_array_equal(mass_ratios(learning), 1.0)
    assert evaluation.simulation.strength is None
    assert mass_ratios(evaluation).max() - mass_ratios(evaluation).min() > 0.3


@pytest.mark.parametrize(
    ("curriculum", "extra", "message"),
    [
        ('metric: "succes"', "", "metric 'succes' is not one of the task's metrics: success, distance"),
        ('metric: "success" step_up: 0', "", "step_up must be above 0"),
        ('metric: "success" step_down: 1.5', "", "step_down must be in \\[0, 1\\], got 1.5"),
        ('metric: "success" start: -0.1', "", "start must be in \\[0, 1\\]"),
    ],
)
def test_bad_curricula_fail_when_the_task_is_built(curriculum: str, extra: str, message: str) -> None:
    with pytest.raises(ConfigError, match=f"randomization_curriculum: {message}"):
        envs(randomized(curriculum, extra), num_envs=2)


def test_a_curriculum_without_events_fails_when_the_task_is_built() -> None:
    config = text_format.Parse('randomization_curriculum { metric: "success" }', TaskConfig())
    with pytest.raises(ConfigError, match="no events to ease in"):
        envs(config, num_envs=2)


def test_strengths_settle_where_a_third_of_the_episodes_succeed_by_default() -> None:
    curriculum = Curriculum("success")
    rng = np.random.default_rng(0)
    strength = np.zeros(20000)
    for _ in range(200):  # each episode succeeds with probability 1 - strength (harder at higher strength)
        strength = curriculum.next_strength(np, strength, np.ones(20000, bool), rng.uniform(size=20000) > strength)
    assert abs((1 - strength).mean() - 1 / 3) < 0.03
