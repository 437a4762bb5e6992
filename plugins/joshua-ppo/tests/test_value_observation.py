"""An asymmetric actor-critic: where the task adds observation noise, PPO's separate value network learns from the
observation without it (the policy still sees the noisy one), as Isaac Lab's and MuJoCo Playground's critics do."""

from __future__ import annotations

import jax
import numpy as np
import pytest
from google.protobuf import text_format

from joshua_core.config_pb2 import TaskConfig
from joshua_mjx import MjxEnv, Physics, make_mjx_env
from joshua_ppo.iteration import _Iteration, make_iteration
from joshua_ppo.normalizer import fresh_statistics
from joshua_ppo.settings import NetworkSettings, OptimizationSettings, ReturnSettings, RolloutSettings
from joshua_ppo.state import init_state

pytestmark = pytest.mark.slow  # every test here trains

NOISE = """
events { name: "noise" term: "observation_noise" mode: INTERVAL interval_steps: 1 params { key: "std" value: "3" } }
"""
SEPARATE = NetworkSettings(hidden_sizes=(16,), value_hidden_sizes=(16,))


@pytest.fixture(scope="module")
def env() -> MjxEnv:
    # on MuJoCo Warp, whose steps compile in seconds (each test compiles iterations; MJX-JAX's took 14-40 s each)
    pytest.importorskip("mujoco_warp", reason="MJX-Warp needs joshua-mjx[warp] (warp-lang, mujoco-warp)")
    config = text_format.Parse(NOISE, TaskConfig(episode_length=50))
    return make_mjx_env("ant_locomotion", 8, model_path="ant/ant_mjx.xml", task_config=config, physics=Physics("warp"))


def test_the_separate_value_network_sees_the_observation_without_noise(env: MjxEnv) -> None:
    settings = (RolloutSettings(num_steps=2), OptimizationSettings(minibatch_size=8), ReturnSettings())
    separate = _Iteration(env, *settings, SEPARATE)
    shared = _Iteration(env, *settings, NetworkSettings(hidden_sizes=(16,)))
    stats = fresh_statistics(env.observation_size)
    state = env.step(env.reset(jax.random.PRNGKey(0)), np.zeros((8, env.action_size), np.float32))  # noise drawn
    for steps in (separate, shared):
        params = steps.net.init(jax.random.PRNGKey(1), state.observation)["params"]
        _, (transition, _) = jax.jit(steps.env_step)((state, params, stats), jax.random.PRNGKey(2))

        def value(observation: jax.Array, value_observation: jax.Array | None) -> np.ndarray:
            return np.asarray(steps.apply(params, stats, observation, value_observation)[2])  # noqa: B023

        if steps is shared:  # one trunk reads one observation: the policy's
            assert transition.value_observation is None
            np.testing.assert_allclose(transition.value, value(state.observation, None), rtol=1e-5, atol=1e-5)
            continue
        np.testing.assert_array_equal(transition.value_observation, state.value_observation)
        np.testing.assert_allclose(transition.value, value(state.observation, state.value_observation), rtol=1e-5)
        assert np.abs(value(state.observation, None) - transition.value).max() > 1e-2  # the noise would move it


@pytest.mark.parametrize("recompute", [False, True])
def test_iterations_learn_with_the_clean_view_in_either_advantage_mode(env: MjxEnv, recompute: bool) -> None:
    """The clean view travels through the minibatches (whole unrolls when advantages are recomputed) into the
    value loss: the iteration runs and moves every parameter of both networks."""
    optimization = OptimizationSettings(num_epochs=2, minibatch_size=8)
    returns = ReturnSettings(recompute_advantages=recompute)
    iteration = make_iteration(
        env, rollout=RolloutSettings(num_steps=4), optimization=optimization, returns=returns, network=SEPARATE
    )
    state = init_state(env, seed=0, network=SEPARATE, optimization=optimization)
    before = jax.tree.map(np.asarray, state.params)
    state, metrics = iteration(state)
    assert bool(metrics["params_finite"]) and np.isfinite(float(metrics["value_loss"]))
    moved = jax.tree.map(lambda old, new: float(np.abs(np.asarray(new) - old).max()), before, state.params)
    assert min(jax.tree.leaves(moved)) > 0, moved
