"""BatchedVectorEnv on real MuJoCo: every task runs, autoreset and truncation, seeding, clipping,
Gymnasium registration, rendering, and the Ant task against Gymnasium's own Ant-v5."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import gymnasium
import mujoco
import numpy as np
import pytest
from google.protobuf import text_format

import joshua_mujoco.envs
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.kinds import Kind
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_mujoco.vector import BatchedVectorEnv, make_vector_env, vector_env_from_config
from joshua_tasks import TASKS


@pytest.fixture(scope="module")
def plugins() -> PluginHost:
    return PluginHost.discover()


def run(env: BatchedVectorEnv, steps: int, seed: int) -> list[tuple[np.ndarray, ...]]:
    rng = np.random.default_rng(seed)
    return [env.step(rng.uniform(-1.2, 1.2, env.action_space.shape))[:4] for _ in range(steps)]


@pytest.mark.parametrize("task", sorted(TASKS))
def test_every_task_steps_1000_times_without_nan(task: str, plugins: PluginHost) -> None:
    env = make_vector_env(task, 4, seed=1, plugins=plugins)
    assert env.single_observation_space.dtype == np.float32 and env.single_action_space.dtype == np.float32
    episodes = 0
    for observation, reward, terminated, truncated in run(env, 1000, seed=2):
        assert observation.shape == (4, env.single_observation_space.shape[0])
        assert np.isfinite(observation).all() and np.isfinite(reward).all()
        episodes += int((terminated | truncated).sum())
    assert episodes >= 4  # every task truncates within 1000 steps
    env.close()


def test_same_step_autoreset_reports_the_final_observation_and_episode(plugins: PluginHost) -> None:
    env = make_vector_env("so_arm100_reach", 3, seed=0, plugins=plugins, episode_length=5)
    assert env.metadata["autoreset_mode"] == gymnasium.vector.AutoresetMode.SAME_STEP
    first, _ = env.reset(seed=0)
    for step in range(1, 6):
        observation, reward, terminated, truncated, infos = env.step(np.full((3, 6), 0.5))
        assert not terminated.any()
        assert truncated.all() == (step == 5)
    assert infos["_final_obs"].all() and infos["_episode"].all()
    assert set(infos["episode"]) == {"r", "l", "failed", "reward/distance", "reward/near", "reward/action_rate"}
    np.testing.assert_array_equal(infos["episode"]["l"], [5, 5, 5])
    assert infos["episode"]["failed"].tolist() == [False, False, False]
    # the final observation is of the moved arm; the returned one is the new episode's first (action 0)
    last_action = slice(-6, None)
    np.testing.assert_allclose(infos["final_obs"][:, last_action], 0.5)
    np.testing.assert_array_equal(observation[:, last_action], 0.0)
    assert not np.allclose(observation, first)  # new random targets and joint noise
    assert np.all(env.simulation.episode_step == 0)


def test_termination_resets_only_the_finished_environment(plugins: PluginHost) -> None:
    env = make_vector_env("ant_locomotion", 2, seed=0, plugins=plugins)
    env.simulation.qpos[1, 2] = 3.0  # lift the second torso far above the healthy range
    _, reward, terminated, truncated, infos = env.step(np.zeros((2, 8)))
    np.testing.assert_array_equal(terminated, [False, True])
    assert not truncated.any() and list(infos["_final_obs"]) == [False, True]
    assert infos["reward_terms"]["healthy"][1] == 0.0 and infos["reward_terms"]["healthy"][0] == 1.0
    assert env.simulation.qpos[1, 2] < 1.0 and env.simulation.episode_step.tolist() == [1, 0]


def test_same_seed_same_episodes_and_thread_count_does_not_matter(plugins: PluginHost) -> None:
    first = make_vector_env("so_arm100_pick_place", 3, seed=7, plugins=plugins, nthread=1)
    second = make_vector_env("so_arm100_pick_place", 3, seed=7, plugins=plugins, nthread=2)
    other = make_vector_env("so_arm100_pick_place", 3, seed=8, plugins=plugins)
    a, b, c = run(first, 30, seed=0), run(second, 30, seed=0), run(other, 30, seed=0)
    for step_a, step_b in zip(a, b, strict=True):
        for x, y in zip(step_a, step_b, strict=True):
            np.testing.assert_array_equal(x, y)
    assert not np.allclose(a[0][0], c[0][0])
    again, _ = first.reset(seed=7)
    np.testing.assert_array_equal(again, second.reset(seed=7)[0])


def test_actions_are_clipped_and_bad_actions_rejected(plugins: PluginHost) -> None:
    clipped = make_vector_env("ant_locomotion", 2, seed=3, plugins=plugins)
    bounded = make_vector_env("ant_locomotion", 2, seed=3, plugins=plugins)
    action = np.tile([5.0, -5.0, 0.2, 1.0, -1.0, 30.0, 0.0, -0.3], (2, 1))
    result = clipped.step(action)
    expected = bounded.step(np.clip(action, -1, 1))
    np.testing.assert_array_equal(result[0], expected[0])
    assert result[1] == pytest.approx(expected[1])
    with pytest.raises(ValueError, match=r"shape \(2, 8\)"):
        clipped.step(np.zeros(7))
    with pytest.raises(ValueError, match=r"NaN or infinity for environments \[1\]"):
        clipped.step(np.array([[0.0] * 8, [np.nan] + [0.0] * 7]))
    with pytest.raises(ValueError, match="step expects real actions, got complex values"):
        clipped.step(np.full((2, 8), 0.1 + 1j))


def test_the_docs_say_our_ant_integrates_unlike_stock_ant_v5() -> None:
    """Stock Ant-v5 sets RK4 and ant.xml keeps MuJoCo's Euler: tasks.md must state it, not call returns comparable."""
    stock = gymnasium.make("Ant-v5").unwrapped.model.opt.integrator
    ours = mujoco.MjModel.from_xml_path(str(resolve_data_path("ant/ant.xml"))).opt.integrator
    assert (stock, ours) == (mujoco.mjtIntegrator.mjINT_RK4, mujoco.mjtIntegrator.mjINT_EULER)
    tasks = " ".join((Path(__file__).parents[3] / "docs" / "tasks.md").read_text().split())
    assert "comparable with published Ant-v5 results" not in tasks.replace("not comparable with published", "")
    assert 'integrator="RK4"' in tasks and "semi-implicit Euler" in tasks


def test_ant_matches_gymnasium_ant_v5_on_the_same_model(plugins: PluginHost) -> None:
    reference = gymnasium.make("Ant-v5", xml_file=str(resolve_data_path("ant/ant.xml"))).unwrapped
    reference.reset(seed=3)
    env = make_vector_env("ant_locomotion", 1, seed=0, plugins=plugins)
    simulation = env.simulation
    simulation.qpos[0], simulation.qvel[0] = reference.data.qpos, reference.data.qvel
    simulation.physics.batch.forward()
    simulation.prev_qpos[:] = simulation.qpos
    rng = np.random.default_rng(0)
    forward = np.zeros(2)
    for _ in range(200):
        action = rng.uniform(-0.4, 0.4, 8)
        expected, _, expected_terminated, _, info = reference.step(action)
        observation, _, terminated, _, infos = env.step(action[None])
        terms = {name: value[0] for name, value in infos["reward_terms"].items()}
        np.testing.assert_allclose(observation[0], expected, rtol=1e-5, atol=1e-5)
        assert terms["ctrl_cost"] == pytest.approx(info["reward_ctrl"], abs=1e-9)
        assert terms["contact_cost"] == pytest.approx(info["reward_contact"], abs=1e-9)
        assert terms["healthy"] == info["reward_survive"] and terminated[0] == expected_terminated
        forward += terms["forward"], info["reward_forward"]
    # Gymnasium differences body positions that lag one substep; the sums over an episode agree
    assert forward[0] == pytest.approx(forward[1], rel=0.02)
    assert abs(forward[0]) > 1.0


# Run in a fresh interpreter that has imported nothing of joshua: the "module:id" form of gymnasium.make
# imports and registers; then every registered id is made by its bare id and passes Gymnasium's checker.
FRESH_MAKE = """
import sys, warnings
import gymnasium
from gymnasium.utils.env_checker import check_env
warnings.filterwarnings("ignore", ".*Box observation space (minimum|maximum) value is")
assert not [name for name in sys.modules if name.startswith("joshua")]
gymnasium.make("joshua_mujoco.envs:joshua/SoArm100Reach-v0").close()
import joshua_mujoco.envs
for env_id, task in joshua_mujoco.envs.register_envs().items():
    env = gymnasium.make(env_id)
    check_env(env.unwrapped, skip_render_check=True)
    observation, _ = env.reset(seed=0)
    assert env.observation_space.contains(observation), env_id
    assert env.spec.kwargs["task"] == task
    env.close()
    print(env_id)
"""


def test_gymnasium_make_for_every_registered_task(plugins: PluginHost) -> None:
    done = subprocess.run([sys.executable, "-c", FRESH_MAKE], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    made = done.stdout.split()
    assert made == [joshua_mujoco.envs.env_id(task) for task in plugins.names(Kind.TASK)]
    assert {"joshua/SoArm100Reach-v0", "joshua/AntLocomotion-v0", "joshua/IsaacAntLocomotion-v0"} <= set(made)
    assert set(TASKS) <= set(plugins.names(Kind.TASK))
    vector = gymnasium.make_vec("joshua/SoArm100Reach-v0", num_envs=2, vectorization_mode="vector_entry_point")
    assert isinstance(vector, BatchedVectorEnv) and vector.num_envs == 2


def test_gymnasium_make_sets_the_time_limit_and_dt_of_the_task() -> None:
    env = gymnasium.make("joshua/AntLocomotion-v0")
    spec = TASKS["ant_locomotion"]
    assert env.spec.max_episode_steps == spec.episode_length == 1000
    assert env.unwrapped.dt == pytest.approx(0.05)  # frame skip 5 x 0.01 s, as Ant-v5
    env.reset(seed=0)
    steps, truncated, terminated = 0, False, False
    while not (truncated or terminated):  # zero actions: the ant stands, so the time limit ends the episode
        _, _, terminated, truncated, _ = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
        steps += 1
    assert truncated and not terminated and steps == 1000
    env.close()


def test_render_frame_draws_the_target(plugins: PluginHost) -> None:
    env = make_vector_env("so_arm100_reach", 2, seed=0, plugins=plugins)
    env.simulation.commands["target"][1] = env.simulation.commands["target"][0]
    with_marker = env.render_frame(1, width=160, height=120)
    env.simulation.commands["target"][1] = [5.0, 5.0, 5.0]  # out of view
    without = env.render_frame(1, width=160, height=120)
    assert with_marker.shape == (120, 160, 3) and with_marker.dtype == np.uint8
    green = (with_marker[..., 1].astype(int) - with_marker[..., 0]) > 80
    assert green.sum() > 5 and ((without[..., 1].astype(int) - without[..., 0]) > 80).sum() < green.sum()
    env.close()


def test_vector_env_from_training_config(plugins: PluginHost) -> None:
    training = text_format.Parse(
        'task: "so_arm100_reach" model_path: "so_arm100/scene.xml" num_envs: 3 seed: 4 nthread: 1 '
        'task_config { episode_length: 2 terms { name: "near" weight: 0 } }',
        TrainingConfig(),
    )
    env = vector_env_from_config(training, plugins)
    assert env.num_envs == 3 and env.nthread == 1 and env.task.episode_length == 2
    assert [term.name for term in env.task.reward_terms] == ["distance", "action_rate"]
    with pytest.raises(ConfigError, match="training.task is empty"):
        vector_env_from_config(TrainingConfig(model_path="so_arm100/scene.xml"), plugins)


def test_reset_mask_resets_only_the_chosen_environments(plugins: PluginHost) -> None:
    env = make_vector_env("so_arm100_reach", 2, seed=0, plugins=plugins)
    moved, *_ = env.step(np.full((2, 6), 0.8))
    observation, _ = env.reset(options={"reset_mask": np.array([False, True])})
    np.testing.assert_array_equal(observation[0], moved[0])
    assert env.simulation.episode_step.tolist() == [1, 0] and not np.allclose(observation[1], moved[1])
