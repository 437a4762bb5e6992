"""SameStepVecEnv behaves exactly like SB3's own DummyVecEnv + VecMonitor on the same environments."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from stable_baselines3 import PPO
from stable_baselines3.common.logger import Logger
from stable_baselines3.common.vec_env import DummyVecEnv, VecCheckNan, VecMonitor, VecNormalize

from joshua_sb3.vec_env import SameStepVecEnv

NUM_ENVS = 4


def same_step_vector_env(env_id: str, **kwargs: object) -> gymnasium.vector.VectorEnv:
    return gymnasium.make_vec(
        env_id,
        num_envs=NUM_ENVS,
        vectorization_mode="sync",
        vector_kwargs={"autoreset_mode": gymnasium.vector.AutoresetMode.SAME_STEP},
        **kwargs,
    )


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [("CartPole-v1", {}), ("Pendulum-v1", {"max_episode_steps": 37})],  # terminations; truncations
)
def test_matches_dummy_vec_env_step_for_step(env_id: str, kwargs: dict[str, object]) -> None:
    ours = SameStepVecEnv(same_step_vector_env(env_id, **kwargs))
    reference = VecMonitor(DummyVecEnv([lambda: gymnasium.make(env_id, **kwargs) for _ in range(NUM_ENVS)]))
    ours.seed(7)
    reference.seed(7)
    np.testing.assert_array_equal(ours.reset(), reference.reset())
    ours.action_space.seed(0)
    episodes_checked = {"terminated": 0, "truncated": 0}
    for _ in range(300):
        actions = np.stack([ours.action_space.sample() for _ in range(NUM_ENVS)])
        observations, rewards, dones, infos = ours.step(actions)
        ref_observations, ref_rewards, ref_dones, ref_infos = reference.step(actions)
        np.testing.assert_array_equal(observations, ref_observations)
        np.testing.assert_array_equal(rewards, ref_rewards)
        np.testing.assert_array_equal(dones, ref_dones)
        assert observations.dtype == ref_observations.dtype and rewards.dtype == ref_rewards.dtype
        for index in np.flatnonzero(dones):
            info, ref_info = infos[index], ref_infos[index]
            np.testing.assert_array_equal(info["terminal_observation"], ref_info["terminal_observation"])
            assert info["TimeLimit.truncated"] == ref_info["TimeLimit.truncated"]
            assert info["episode"]["r"] == pytest.approx(ref_info["episode"]["r"], rel=1e-6)
            assert info["episode"]["l"] == ref_info["episode"]["l"]
            episodes_checked["truncated" if info["TimeLimit.truncated"] else "terminated"] += 1
        for index in np.flatnonzero(~dones):
            assert "terminal_observation" not in infos[index] and "episode" not in infos[index]
    expected_kind = "terminated" if env_id == "CartPole-v1" else "truncated"
    assert episodes_checked[expected_kind] >= NUM_ENVS


def test_sb3_wrappers_and_algorithms_run_on_it(silent_logger: Logger) -> None:
    env = VecNormalize(VecCheckNan(SameStepVecEnv(same_step_vector_env("Pendulum-v1")), raise_exception=True))
    model = PPO("MlpPolicy", env, n_steps=32, batch_size=64, n_epochs=1, seed=0, device="cpu")
    model.set_logger(silent_logger)
    model.learn(total_timesteps=4 * NUM_ENVS * 32)
    assert model.num_timesteps == 4 * NUM_ENVS * 32
    assert len(model.ep_info_buffer) == 0  # Pendulum's episodes last 200 steps: none finished in 128
    model.learn(total_timesteps=3 * NUM_ENVS * 32, reset_num_timesteps=False)  # to step 224 of each env
    assert len(model.ep_info_buffer) == NUM_ENVS and all(info["l"] == 200 for info in model.ep_info_buffer)


def test_rejects_next_step_autoreset() -> None:
    env = gymnasium.make_vec("Pendulum-v1", num_envs=2, vectorization_mode="sync")
    with pytest.raises(ValueError, match="SAME_STEP"):
        SameStepVecEnv(env)
