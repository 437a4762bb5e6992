"""The `usd` backend: both Isaac tasks step on NUMPY (mujoco.batch) and JAX (MJX on the CPU) environments with
the same observations and rewards for the same actions; a clear error without joshua-mjx. (Their SB3 views are
joshua-sb3's: plugins/joshua-sb3/tests/test_task_envs.py.)"""

from __future__ import annotations

import sys

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from joshua_core.errors import ConfigError
from joshua_core.interfaces import EnvKind, EnvSpec
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_core.tasks.task import load_task_spec
from joshua_mujoco import MuJoCoEngine
from joshua_mujoco.envs import register_envs
from joshua_mujoco.vector import task_config_from_options
from joshua_usd.backend import UsdBackend

# The tasks on the shipped USD robots (MJX compiles the imported model as it does an MJCF one).
MODELS = {"isaac_ant_locomotion": "isaac/ant.usd", "isaac_trileg": "isaac/trileg.usd"}
NO_RESET_NOISE = {"reset_joints_uniform": {"weight": 0}, "reset_qvel_normal": {"weight": 0}}
NUM_ENVS, STEPS, EPISODE_LENGTH = 3, 4, 6
# float32 MJX against float64 MuJoCo over 4 steps of the Ant's contact-free motion
OBSERVATION_TOLERANCE, REWARD_TOLERANCE = 2e-3, 3e-3


def spec(task: str, num_envs: int = NUM_ENVS) -> EnvSpec:
    config = task_config_from_options({"terms": NO_RESET_NOISE, "episode_length": EPISODE_LENGTH})
    return EnvSpec(task, num_envs, model_path=resolve_data_path(MODELS[task]), task_config=config, nthread=1)


@pytest.fixture(scope="module")
def plugins() -> PluginHost:
    return PluginHost.discover()


@pytest.fixture(scope="module")
def ant_jax(plugins: PluginHost):  # type: ignore[no-untyped-def]
    return plugins.backend("usd").create_envs(spec("isaac_ant_locomotion"), EnvKind.JAX, plugins)


def test_the_plugin_registers_the_backend_with_both_kinds(plugins: PluginHost) -> None:
    assert isinstance(plugins.backend("usd"), UsdBackend)
    plugins.check_env_kinds("sb3", "usd", needs=[EnvKind.NUMPY])
    plugins.check_env_kinds("ppo", "usd", needs=[EnvKind.JAX])


# The Ant only: the USD trileg's MJX compile took 39 s of CI's 2 cores. MJX-JAX steps the trileg's MJCF as MuJoCo
# does in joshua-mjx's test_warp_parity.py, and the USD trileg trains on the usd backend in test_isaac_presets.py
@pytest.mark.slow
def test_numpy_and_jax_environments_agree(plugins: PluginHost, ant_jax) -> None:  # type: ignore[no-untyped-def]
    task, backend = "isaac_ant_locomotion", plugins.backend("usd")
    cpu = backend.create_envs(spec(task), EnvKind.NUMPY, plugins)
    cpu_observation, _ = cpu.reset(seed=0)
    state = ant_jax.reset(jax.random.PRNGKey(0))
    np.testing.assert_allclose(np.asarray(state.observation), cpu_observation, atol=1e-5)
    for action in 0.5 * np.random.default_rng(0).uniform(-1, 1, (STEPS, NUM_ENVS, cpu.task.action_size)):
        cpu_observation, cpu_reward, _, _, cpu_info = cpu.step(action)
        state = ant_jax.step(state, jnp.asarray(action))
        np.testing.assert_allclose(np.asarray(state.observation), cpu_observation, atol=OBSERVATION_TOLERANCE)
        np.testing.assert_allclose(np.asarray(state.reward), cpu_reward, atol=REWARD_TOLERANCE)
        for name, value in cpu_info["reward_terms"].items():
            np.testing.assert_allclose(np.asarray(state.reward_terms[name]), value, atol=REWARD_TOLERANCE)
    assert np.abs(cpu_reward).min() > 0.1  # alive, upright and heading rewards: something was compared
    cpu.close()


def test_jax_environments_without_joshua_mjx_say_to_install_it(
    plugins: PluginHost, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "joshua_mjx", None)  # as if it were not installed
    with pytest.raises(ConfigError, match=r"need joshua-mjx, which is not installed; install joshua-mjx"):
        UsdBackend().create_envs(spec("isaac_trileg"), EnvKind.JAX, plugins)


def test_engines_are_mujoco_engines_of_any_model_format(plugins: PluginHost) -> None:
    with UsdBackend().create_engine(resolve_data_path(MODELS["isaac_trileg"]), plugins) as engine:
        assert isinstance(engine, MuJoCoEngine) and engine.model.nu == 6
        engine.step(5)
        assert engine.time == pytest.approx(5 * 0.004)


@pytest.mark.parametrize(
    ("env_id", "task"),
    [("joshua/IsaacAntLocomotion-v0", "isaac_ant_locomotion"), ("joshua/IsaacTrileg-v0", "isaac_trileg")],
)
def test_the_isaac_tasks_have_gymnasium_ids(env_id: str, task: str, plugins: PluginHost) -> None:
    assert register_envs(plugins)[env_id] == task
    env = gymnasium.make(env_id)
    assert env.spec.max_episode_steps == load_task_spec(task, plugins).episode_length
    observation, _ = env.reset(seed=0)
    assert observation.shape == env.observation_space.shape and np.isfinite(observation).all()
    env.close()
