"""joshua-sb3's views of a task's environments as SB3 VecEnvs: JaxVecEnv over JAX environments reports
episodes the way SB3 expects and trains with PPO; AntEnv and TrilegEnv (joshua-usd's Isaac tasks) on the CPU
train with PPO, on "cuda" they are MJX over the GPUs, and without a GPU they are a clear error."""

from __future__ import annotations

import jax
import numpy as np
import pytest
from stable_baselines3 import PPO
from stable_baselines3.common.logger import Logger

from joshua_core.errors import ConfigError
from joshua_core.interfaces import EnvKind, EnvSpec
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_mujoco.vector import task_config_from_options
from joshua_sb3 import AntEnv, JaxVecEnv, TrilegEnv, task_envs

# The Isaac tasks on the shipped USD robots (joshua-usd).
MODELS = {"isaac_ant_locomotion": "isaac/ant.usd", "isaac_trileg": "isaac/trileg.usd"}
NO_RESET_NOISE = {"reset_joints_uniform": {"weight": 0}, "reset_qvel_normal": {"weight": 0}}
NUM_ENVS, EPISODE_LENGTH = 3, 6


@pytest.fixture(scope="module")
def ant_jax():  # type: ignore[no-untyped-def]
    plugins = PluginHost.discover()
    config = task_config_from_options({"terms": NO_RESET_NOISE, "episode_length": EPISODE_LENGTH})
    model = resolve_data_path(MODELS["isaac_ant_locomotion"])
    spec = EnvSpec("isaac_ant_locomotion", NUM_ENVS, model_path=model, task_config=config)
    return plugins.backend("mjx").create_envs(spec, EnvKind.JAX, plugins)


@pytest.mark.slow  # compiles the JAX Ant environments for SB3: about 80 s on 2 cores
def test_jax_vec_env_reports_episodes_as_sb3_expects(ant_jax) -> None:  # type: ignore[no-untyped-def]
    env = JaxVecEnv(ant_jax, seed=3)
    first = env.reset()
    assert first.shape == (NUM_ENVS, ant_jax.observation_size) and first.dtype == np.float32
    actions = np.full((NUM_ENVS, 8), 0.3, np.float32)
    returns = np.zeros(NUM_ENVS)
    for step in range(1, EPISODE_LENGTH + 1):
        observation, reward, dones, infos = env.step(actions)
        returns += reward
        assert dones.all() == (step == EPISODE_LENGTH) and dones.any() == (step == EPISODE_LENGTH)
    for index, info in enumerate(infos):
        assert info["TimeLimit.truncated"] and info["episode"]["l"] == EPISODE_LENGTH
        assert info["episode"]["r"] == pytest.approx(returns[index], rel=1e-5)
        assert not np.allclose(info["terminal_observation"], observation[index])
    np.testing.assert_allclose(observation, first, atol=1e-5)  # no reset noise: the next episode starts alike


@pytest.mark.slow
def test_ppo_trains_on_the_jax_vec_env(ant_jax, silent_logger: Logger) -> None:  # type: ignore[no-untyped-def]
    model = PPO("MlpPolicy", JaxVecEnv(ant_jax), n_steps=8, batch_size=12, n_epochs=1, device="cpu", seed=0)
    model.set_logger(silent_logger)
    model.learn(total_timesteps=2 * 8 * NUM_ENVS)
    assert model.num_timesteps == 2 * 8 * NUM_ENVS and len(model.ep_info_buffer) >= NUM_ENVS


def test_ant_env_on_the_cpu_trains_with_sb3_ppo(silent_logger: Logger) -> None:
    env = AntEnv(num_envs=4, device="cpu", model_path=MODELS["isaac_ant_locomotion"])
    assert (env.num_envs, env.observation_space.shape, env.action_space.shape) == (4, (60,), (8,))
    model = PPO("MlpPolicy", env, n_steps=64, batch_size=64, n_epochs=2, device="cpu", seed=0)
    model.set_logger(silent_logger)
    before = [parameter.detach().clone() for parameter in model.policy.parameters()]
    model.learn(total_timesteps=512)
    assert model.num_timesteps == 512
    assert any(
        not np.allclose(a.numpy(), b.detach().numpy()) for a, b in zip(before, model.policy.parameters(), strict=True)
    )
    env.close()


def test_cuda_without_a_gpu_is_a_clear_error() -> None:
    assert not [device for device in jax.devices() if device.platform == "gpu"]  # this test needs a CPU-only JAX
    with pytest.raises(ConfigError, match=r'device="cuda": JAX sees no GPU .*use device="cpu"'):
        TrilegEnv(num_envs=2, device="cuda", model_path=MODELS["isaac_trileg"])
    with pytest.raises(ConfigError, match="device must be one of cuda, cpu"):
        TrilegEnv(num_envs=2, device="tpu")


def test_cuda_puts_the_environments_on_mjx_over_the_gpus(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(task_envs, "gpu_devices", jax.devices)  # the CPU stands in for the GPUs
    env = AntEnv(num_envs=2, device="cuda", model_path=MODELS["isaac_ant_locomotion"])
    assert isinstance(env, JaxVecEnv) and env.env.mesh.devices.tolist() == jax.devices()
    assert (env.num_envs, env.observation_space.shape, env.action_space.shape) == (2, (60,), (8,))
