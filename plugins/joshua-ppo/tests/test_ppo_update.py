"""The PPO update itself: both advantage estimators against a step-by-step reference; advantages recomputed
per minibatch agree with the once-per-iteration ones while the value network is still the collecting one,
and differ once it has learned; the adaptive learning rate follows the KL divergence; the KL stop skips the rest of
an update."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

from joshua_core.config_pb2 import TaskConfig
from joshua_core.errors import ConfigError
from joshua_mjx import MjxEnv, Physics, make_mjx_env
from joshua_ppo.advantages import estimate_advantages
from joshua_ppo.batches import Transition
from joshua_ppo.iteration import make_iteration
from joshua_ppo.losses import imitation_loss
from joshua_ppo.optimizer import adapt_learning_rate
from joshua_ppo.settings import (
    LEARNING_RATE_BOUNDS,
    NetworkSettings,
    OptimizationSettings,
    ReturnSettings,
    RolloutSettings,
)
from joshua_ppo.state import TrainingState, init_state

ROLLOUT = RolloutSettings(num_steps=5, unrolls_per_iteration=2)  # of the 4 environments of `env`
# without observation normalisation: the statistics change between collecting and updating, and with
# them the values the advantages are computed from
NETWORK = NetworkSettings(hidden_sizes=(16,), value_hidden_sizes=(16,), normalize_observations=False)
LOSSES = ("policy_loss", "value_loss", "approx_kl")


@pytest.fixture(scope="module")
def env() -> MjxEnv:
    # 3-step episodes: unrolls of 5 steps cross truncations, so the final-observation bootstrap counts too; on
    # MuJoCo Warp, whose steps compile in seconds (each test compiles an iteration; MJX-JAX's took 25-50 s each)
    pytest.importorskip("mujoco_warp", reason="MJX-Warp needs joshua-mjx[warp] (warp-lang, mujoco-warp)")
    config = TaskConfig(episode_length=3)
    return make_mjx_env("ant_locomotion", 4, model_path="ant/ant_mjx.xml", task_config=config, physics=Physics("warp"))


def update_losses(env: MjxEnv, recompute: bool, num_epochs: int) -> np.ndarray:
    """The losses of one iteration's update, averaged over its epochs."""
    # one minibatch of the whole batch: the losses do not depend on how the batch is shuffled
    optimization = OptimizationSettings(num_epochs=num_epochs, minibatch_size=40, learning_rate=1e-2)
    returns = ReturnSettings(gamma=0.9, reward_scaling=0.1, recompute_advantages=recompute)
    state = init_state(env, seed=0, network=NETWORK, optimization=optimization)
    iteration = make_iteration(env, rollout=ROLLOUT, optimization=optimization, returns=returns, network=NETWORK)
    _, metrics = iteration(state)
    losses = np.array([float(metrics[name]) for name in LOSSES])
    assert np.isfinite(losses).all() and np.abs(losses).max() > 0, losses
    return losses


@pytest.mark.slow  # compiles a whole PPO update: about 95 s on 2 cores
def test_recomputed_advantages_match_while_the_value_network_is_unchanged(env: MjxEnv) -> None:
    # one epoch of one minibatch: its losses are computed before the first gradient step
    once, recomputed = update_losses(env, False, 1), update_losses(env, True, 1)
    np.testing.assert_allclose(recomputed, once, rtol=1e-4, atol=1e-7)


@pytest.mark.slow
def test_recomputed_advantages_follow_the_learning_value_network(env: MjxEnv) -> None:
    once, recomputed = update_losses(env, False, 3), update_losses(env, True, 3)
    assert np.abs(recomputed - once).max() > 1e-3 * np.abs(once).max(), (once, recomputed)


def test_recomputing_needs_minibatches_of_whole_unrolls(env: MjxEnv) -> None:
    optimization = OptimizationSettings(minibatch_size=8)
    with pytest.raises(ConfigError, match="must be a multiple of num_steps x devices = 5"):
        make_iteration(
            env,
            rollout=ROLLOUT,
            optimization=optimization,
            returns=ReturnSettings(recompute_advantages=True),
            network=NETWORK,
        )


def four_step_iteration(env: MjxEnv, **guard: float) -> tuple[TrainingState, dict[str, float]]:
    """The state and metrics after one iteration of 2 epochs of 2 minibatches at learning rate 1e-3, with the KL
    `guard` given (desired_kl or max_kl)."""
    optimization = OptimizationSettings(num_epochs=2, minibatch_size=20, learning_rate=1e-3, **guard)
    state = init_state(env, seed=0, network=NETWORK, optimization=optimization)
    iteration = make_iteration(
        env, rollout=ROLLOUT, optimization=optimization, returns=ReturnSettings(), network=NETWORK
    )
    state, metrics = iteration(state)
    return state, {name: float(value) for name, value in metrics.items()}


def learning_rates(env: MjxEnv, desired_kl: float) -> tuple[float, float]:
    """The learning rate after the four steps, and its mean over them."""
    state, metrics = four_step_iteration(env, desired_kl=desired_kl)
    return float(state.opt_state.hyperparams["learning_rate"]), metrics["learning_rate"]


@pytest.mark.slow
def test_adaptive_learning_rate_follows_the_kl_divergence(env: MjxEnv) -> None:
    assert learning_rates(env, 0.0) == pytest.approx((1e-3, 1e-3))  # off: constant
    final, mean = learning_rates(env, 1e-9)  # every move is too far: smaller steps
    assert final < 1e-3 / 1.5**2 and mean < 1e-3
    final, mean = learning_rates(env, 1e3)  # every move is too small: larger steps
    assert final > 1e-3 * 1.5**2 and mean > 1e-3


@pytest.mark.slow
def test_the_kl_guard_measures_the_policy_change_alone(env: MjxEnv) -> None:
    """One epoch of one minibatch: its KL is taken before the first gradient step, where the policy is the one
    that collected, so it is 0 with a KL guard (the adaptive rate or the KL stop), whose update sees the
    statistics the rollout used. Without one, the statistics are updated first (as Brax does) and the same
    policy differs by their drift."""
    network = NetworkSettings(hidden_sizes=(16,), value_hidden_sizes=(16,), normalize_observations=True)
    kls = []
    for guard in ({"desired_kl": 0.01}, {"max_kl": 10.0}, {}):
        optimization = OptimizationSettings(num_epochs=1, minibatch_size=40, **guard)
        state = init_state(env, seed=0, network=network, optimization=optimization)
        returns = ReturnSettings()
        iteration = make_iteration(env, rollout=ROLLOUT, optimization=optimization, returns=returns, network=network)
        before = np.asarray(state.normalizer.mean)
        next_state, metrics = iteration(state)
        assert not np.allclose(next_state.normalizer.mean, before)  # updated in both
        kls.append(abs(float(metrics["approx_kl"])))
    assert max(kls[:2]) < 1e-6 < kls[2], kls


@pytest.mark.slow
def test_max_kl_skips_the_rest_of_an_update_once_the_policy_moved_too_far(env: MjxEnv) -> None:
    """The first gradient step's KL is 0 (the collecting policy's), so it is taken; every later one measures a
    policy that moved, which a tiny max_kl stops: 3 of the 4 steps skipped, Adam stepped once, while the
    schedule's count (what annealing reads) went on. A huge max_kl never stops and changes nothing."""
    unguarded, unguarded_metrics = four_step_iteration(env, max_kl=0.0)
    assert "kl_stopped" not in unguarded_metrics
    state, metrics = four_step_iteration(env, max_kl=1e-9)
    assert metrics["kl_stopped"] == pytest.approx(0.75)
    counts = [int(count) for _, count in optax.tree_utils.tree_get_all_with_path(state.opt_state, "count")]
    assert counts == [4, 1], counts  # the schedule's, Adam's
    moved = jax.tree.map(lambda a, b: float(np.abs(a - b).max()), state.params, unguarded.params)
    assert max(jax.tree.leaves(moved)) > 1e-5  # one step taken, not four
    state, metrics = four_step_iteration(env, max_kl=1e9)
    assert metrics["kl_stopped"] == 0.0
    jax.tree.map(lambda a, b: np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6), state.params, unguarded.params)


def test_adaptive_learning_rate_stays_within_its_bounds() -> None:
    lower, upper = LEARNING_RATE_BOUNDS
    assert float(adapt_learning_rate(jnp.float32(lower), jnp.float32(1.0), 0.01)) == pytest.approx(lower)
    assert float(adapt_learning_rate(jnp.float32(upper), jnp.float32(1e-4), 0.01)) == pytest.approx(upper)
    assert float(adapt_learning_rate(jnp.float32(1e-3), jnp.float32(0.01), 0.01)) == pytest.approx(1e-3)
    assert float(adapt_learning_rate(jnp.float32(1e-3), jnp.float32(0.0), 0.01)) == pytest.approx(1e-3)


def reference_advantages(
    value: np.ndarray, last_value: float, steps: list[tuple[float, bool, bool, float]], gamma: float, lam: float
) -> tuple[list[float], list[float], list[float]]:
    """One environment's GAE, lambda-return advantages and lambda-returns, step by step from the definitions.

    steps: (reward, terminated, truncated, final_value) per step."""
    count = len(steps)
    following = [*value[1:], last_value]
    delta, ends = [], []
    for t, (reward, terminated, truncated, final_value) in enumerate(steps):
        bootstrap = final_value if truncated else 0.0 if terminated else following[t]
        delta.append(reward + gamma * bootstrap - value[t])
        ends.append(terminated or truncated)
    gae = [0.0] * count
    for t in reversed(range(count)):
        later = gae[t + 1] if t + 1 < count and not ends[t] else 0.0
        gae[t] = delta[t] + gamma * lam * later
    lambda_return = [gae[t] + value[t] for t in range(count)]
    # r + gamma G_{t+1} - V(s_t), with G the next step's lambda-return in the same episode (else the bootstrap)
    by_return = []
    for t, (reward, *_) in enumerate(steps):
        if ends[t] or t + 1 == count:
            by_return.append(delta[t])
        else:
            by_return.append(reward + gamma * lambda_return[t + 1] - value[t])
    return gae, by_return, lambda_return


def test_both_advantage_estimators_match_their_definitions() -> None:
    gamma, lam = 0.9, 0.8
    rng = np.random.default_rng(0)
    value = rng.normal(size=(6, 3)).astype(np.float32)
    last_value = rng.normal(size=3).astype(np.float32)
    reward = rng.normal(size=(6, 3)).astype(np.float32)
    final_value = rng.normal(size=(6, 3)).astype(np.float32)
    terminated = np.zeros((6, 3), bool)
    truncated = np.zeros((6, 3), bool)
    terminated[2, 0] = True  # env 0 falls at step 2, env 1 is truncated at step 3, env 2 runs through
    truncated[3, 1] = True
    steps = Transition(
        observation=None,
        value_observation=None,
        views=None,
        action=None,
        log_prob=None,
        value=value,
        reward=jnp.asarray(reward),
        terminated=jnp.asarray(terminated),
        truncated=jnp.asarray(truncated),
        final_value=jnp.asarray(final_value),
    )
    results = {}
    for estimator in ("gae", "lambda_return"):
        returns = ReturnSettings(gamma=gamma, gae_lambda=lam, advantage=estimator)
        advantage, target = estimate_advantages(returns, jnp.asarray(value), jnp.asarray(last_value), steps)
        results[estimator] = (np.asarray(advantage), np.asarray(target))
    for env in range(3):
        per_step = list(zip(reward[:, env], terminated[:, env], truncated[:, env], final_value[:, env], strict=True))
        gae, by_return, lambda_return = reference_advantages(value[:, env], last_value[env], per_step, gamma, lam)
        np.testing.assert_allclose(results["gae"][0][:, env], gae, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(results["lambda_return"][0][:, env], by_return, rtol=1e-5, atol=1e-6)
        for estimator in results:  # the value targets are the lambda-returns either way
            np.testing.assert_allclose(results[estimator][1][:, env], lambda_return, rtol=1e-5, atol=1e-6)
    # the two differ inside an episode (by gamma (1 - lambda) times the next step's GAE), not at its end
    difference = np.abs(results["lambda_return"][0] - results["gae"][0])
    assert difference[0, 2] > 1e-3 and difference[2, 0] == 0 and difference[5, 2] == 0


def test_an_unknown_advantage_estimator_is_a_config_error(env: MjxEnv) -> None:
    with pytest.raises(ConfigError, match="advantage 'vtrace' is not one of: gae, lambda_return"):
        make_iteration(
            env,
            rollout=ROLLOUT,
            optimization=OptimizationSettings(minibatch_size=40),
            returns=ReturnSettings(advantage="vtrace"),
            network=NETWORK,
        )


def test_the_imitation_term_is_the_kl_from_the_teacher_and_pulls_the_policy_to_it() -> None:
    rng = np.random.default_rng(0)
    mean, teacher_mean = rng.normal(size=(2, 5, 3)).astype(np.float32)
    log_std, teacher_log_std = rng.normal(scale=0.5, size=(2, 5, 3)).astype(np.float32)
    # KL(N(m1, s1) || N(m2, s2)) = log(s2 / s1) + (s1^2 + (m1 - m2)^2) / (2 s2^2) - 1/2, per dimension
    s1, s2 = np.exp(teacher_log_std), np.exp(log_std)
    expected = (np.log(s2 / s1) + (s1**2 + (teacher_mean - mean) ** 2) / (2 * s2**2) - 0.5).sum(-1).mean()
    assert float(imitation_loss(mean, log_std, teacher_mean, teacher_log_std)) == pytest.approx(expected, rel=1e-5)
    assert float(imitation_loss(mean, log_std, mean, log_std)) == pytest.approx(0.0, abs=1e-6)
    # gradient descent on the policy's outputs alone reaches the teacher's
    grad = jax.jit(jax.grad(imitation_loss, argnums=(0, 1)))
    outputs = (jnp.asarray(mean), jnp.asarray(log_std))
    for _ in range(2000):
        steps = grad(*outputs, teacher_mean, teacher_log_std)
        outputs = tuple(value - 0.5 * step for value, step in zip(outputs, steps, strict=True))
    np.testing.assert_allclose(outputs[0], teacher_mean, atol=1e-3)
    np.testing.assert_allclose(outputs[1], teacher_log_std, atol=1e-3)
