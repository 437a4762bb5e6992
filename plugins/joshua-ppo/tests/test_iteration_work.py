"""The compiled iteration evaluates each network only where its result is used.

`_Iteration.env_step` applies the whole actor-critic to the observation and to the final observation,
and `current_advantages` to the unrolls' last observations, though some of those outputs are never
read: the policy on the final and last observations, and, when advantages are recomputed per
minibatch, the value on the observation. JAX drops that work when it traces the iteration (dead-code
elimination), before XLA sees it; these tests count the networks' first layers in the program JAX hands
to XLA, so that a change which would make the rollout or update evaluate a network twice shows here.
"""

from __future__ import annotations

import re
from collections import Counter
from types import SimpleNamespace

import jax.numpy as jnp
import numpy as np
import pytest

from joshua_core.config_pb2 import TaskConfig
from joshua_core.tasks.episodes import Episode
from joshua_mjx import Physics
from joshua_mjx.env import MjxEnv, make_mjx_env
from joshua_ppo.iteration import _Iteration, episode_metrics, episode_sums, make_iteration
from joshua_ppo.settings import NetworkSettings, OptimizationSettings, ReturnSettings, RolloutSettings
from joshua_ppo.state import abstract_state, init_state

ENVS, STEPS = 12, 5
POLICY, VALUE = 40, 52  # first-layer widths: no MJX array of the Ant has them
# the tuned preset's layout (separate networks, state-dependent std, squashed actions), smaller
NETWORK = NetworkSettings(
    hidden_sizes=(POLICY, 44), value_hidden_sizes=(VALUE, 60), squash_actions=True, state_dependent_std=True
)


@pytest.fixture(scope="module")
def env() -> MjxEnv:
    # the networks' work is the subject, not the physics: MuJoCo Warp's, whose step compiles far sooner than MJX-JAX's
    config, physics = TaskConfig(episode_length=3), Physics("warp")
    return make_mjx_env("ant_locomotion", ENVS, model_path="ant/ant_mjx.xml", task_config=config, physics=physics)


def network_evaluations(env: MjxEnv, recompute: bool, minibatch_size: int) -> Counter[tuple[str, str]]:
    """(network, batch shape) -> how often the lowered iteration applies the network's first layer to a batch
    of that shape (a loop body counts once, however often it runs)."""
    optimization = OptimizationSettings(num_epochs=2, minibatch_size=minibatch_size)
    returns = ReturnSettings(recompute_advantages=recompute, advantage="lambda_return")
    rollout = RolloutSettings(num_steps=STEPS, unrolls_per_iteration=2)
    iteration = make_iteration(env, rollout=rollout, optimization=optimization, returns=returns, network=NETWORK)
    text = iteration.lower(abstract_state(env, network=NETWORK, optimization=optimization)).as_text()
    obs = env.observation_size
    first_layer = rf"stablehlo\.dot_general .*: \(tensor<([0-9x]+)x{obs}xf32>, tensor<{obs}x(\d+)xf32>\)"
    names = {str(POLICY): "policy", str(VALUE): "value"}
    return Counter((names[width], batch) for batch, width in re.findall(first_layer, text))


def test_recomputing_advantages_evaluates_only_what_it_uses(env: MjxEnv) -> None:
    unrolls = 2  # per minibatch: 10 transitions
    evaluations = network_evaluations(env, recompute=True, minibatch_size=unrolls * STEPS)
    assert evaluations == {
        ("policy", f"{ENVS}"): 1,  # per env step: the policy on the observation
        ("value", f"{ENVS}"): 1,  # ... and the value on the final observation alone (on a step truncating many)
        ("value", "1"): 1,  # ... or on the one truncated environment gathered (1 in 64, at least 1)
        ("policy", f"{unrolls}x{STEPS}"): 1,  # per minibatch: both networks on its observations
        ("value", f"{unrolls}x{STEPS}"): 1,
        ("value", f"{unrolls}"): 1,  # ... and the value on its unrolls' last observations
    }, evaluations


def test_advantages_once_per_iteration_evaluate_only_what_they_use(env: MjxEnv) -> None:
    minibatch = 15
    evaluations = network_evaluations(env, recompute=False, minibatch_size=minibatch)
    assert evaluations == {
        ("policy", f"{ENVS}"): 1,  # per env step: the policy on the observation
        # per env step the value on the observation and on the final observation, per unroll on its last
        ("value", f"{ENVS}"): 3,
        ("value", "1"): 1,  # ... the final observation's on the one truncated environment gathered
        ("policy", f"{minibatch}"): 1,  # per minibatch: both networks on its observations
        ("value", f"{minibatch}"): 1,
    }, evaluations


@pytest.mark.parametrize("truncated", [[], [5], [0, 3, 7]])
@pytest.mark.slow
def test_final_values_are_the_value_network_s_where_episodes_were_truncated(env: MjxEnv, truncated: list[int]) -> None:
    """Gathered (one truncated environment: final_rows is 1 of 12) or over every environment (more), the final
    values of truncated episodes are the value network's on their final observations."""
    optimization = OptimizationSettings(num_epochs=1, minibatch_size=ENVS)
    steps = _Iteration(env, RolloutSettings(num_steps=1), optimization, ReturnSettings(), NETWORK)
    state = init_state(env, seed=0, network=NETWORK, optimization=optimization)
    stepped = env.step(state.env_state, jnp.full((ENVS, env.action_size), 0.3))
    mask = jnp.zeros(ENVS, bool).at[jnp.array(truncated, int)].set(True)
    stepped = stepped._replace(truncated=mask)
    final = (stepped.final_observation, steps.value_view(stepped.final_value_observation))
    expected = steps.apply(state.params, state.normalizer, *final)[2]
    got = steps.final_values(state.params, state.normalizer, stepped)
    np.testing.assert_allclose(np.where(mask, got, 0.0), np.where(mask, expected, 0.0), rtol=1e-5, atol=1e-6)


def test_a_failed_simulations_metrics_leave_the_means_finite() -> None:
    # three episodes end; the second's simulation failed (non-finite state), so its distance is not a number
    episode = Episode(
        done=jnp.array([True, True, True, False]),
        return_=jnp.array([1.0, 0.0, 3.0, 9.0]),
        length=jnp.array([10, 4, 10, 7]),
        reward_terms={},
        metrics={"distance": jnp.array([0.2, jnp.nan, 0.4, jnp.nan]), "success": jnp.array([1.0, 0.0, 0.0, 1.0])},
        failed=jnp.array([False, True, False, False]),
    )
    sums = episode_sums(SimpleNamespace(episode=episode), [], ["distance", "success"])  # type: ignore[arg-type]
    means = episode_metrics({name: value.sum() for name, value in sums.items()})
    assert float(means["episodes"]) == 3 and float(means["mean_return"]) == pytest.approx(4.0 / 3)
    assert float(means["failed_episodes"]) == 1  # a count, not a mean
    assert float(means["metrics/distance"]) == pytest.approx(0.3)  # over the two episodes where it is a number
    assert float(means["metrics/success"]) == pytest.approx(1.0 / 3)  # the failed one counted as a failure
