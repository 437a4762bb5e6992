"""The episode bookkeeping every backend shares (joshua_core.tasks.episodes): the same records on numpy
and inside jax.jit, for episodes that run to their length, end by the task's termination, or fail."""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_core.tasks import (
    EpisodeSums,
    StepOutcome,
    Task,
    TaskSpec,
    TermContext,
    TermSpec,
    account_step,
    build_task,
    nonfinite,
)

HEALTHY = {"joint": "root", "min_z": 0.2, "max_z": 1.0}
SPEC = TaskSpec(
    name="bookkeeping",
    summary="an Ant that only has to stay up",
    model_path="ant/ant.xml",
    frame_skip=1,
    episode_length=3,
    observations=(TermSpec("qpos"),),
    rewards=(TermSpec("healthy", 1.0, HEALTHY, name="alive"), TermSpec("action_l2", -0.5, name="ctrl")),
    terminations=(TermSpec("unhealthy", params=HEALTHY),),
    metrics=(TermSpec("healthy", params=HEALTHY, name="up"),),
)
ACTION = 0.2  # every actuator: ctrl cost 0.5 * 8 * 0.04 = 0.16 per step
UP, DOWN = 0.75, 0.1  # torso heights in and below the healthy range


@pytest.fixture(scope="module")
def task() -> Task:
    model = mujoco.MjModel.from_xml_path(str(resolve_data_path(SPEC.model_path)))
    return build_task(SPEC, model, PluginHost.discover())


def heights_and_velocities(task: Task, step: int) -> tuple[np.ndarray, np.ndarray]:
    """Four environments on step `step` (1-3): 0 stays up; 1 falls on step 2; 2's velocities become NaN on
    step 1 (a failed simulation); 3 falls on step 3, the step its episode reaches its length."""
    qpos = np.tile(task.initial_qpos, (4, 1))
    qvel = np.zeros((4, len(task.initial_qvel)))
    qpos[:, 2] = UP
    qpos[1, 2] = DOWN if step == 2 else UP
    qpos[3, 2] = DOWN if step == 3 else UP
    if step == 1:
        qvel[2, 0] = np.nan
    return qpos, qvel


def run(task: Task, xp: Any, dtype: Any) -> list[StepOutcome]:
    """Three steps of the four environments, as a backend does them: account, then restart where done."""

    def account(qpos: Any, qvel: Any, episode_step: Any, sums: EpisodeSums) -> StepOutcome:
        action = xp.full((4, 8), ACTION)
        ctx = TermContext(xp=xp, dt=task.dt, qpos=qpos, qvel=qvel, action=action, episode_step=episode_step)
        return account_step(task, ctx, nonfinite(xp, qpos, qvel), sums, dtype)

    account_fn = jax.jit(account) if xp is jnp else account
    sums = EpisodeSums.zeros(xp, task, 4, dtype)
    episode_step = np.zeros(4, np.int32)
    outcomes = []
    for step in (1, 2, 3):
        qpos, qvel = heights_and_velocities(task, step)
        episode_step = episode_step + 1
        outcome = jax.device_get(account_fn(xp.asarray(qpos), xp.asarray(qvel), xp.asarray(episode_step), sums))
        outcomes.append(outcome)
        sums = outcome.sums
        episode_step = np.where(np.asarray(outcome.episode.done), 0, episode_step)
    return outcomes


def check(outcomes: list[StepOutcome]) -> None:
    first, second, third = (jax.tree.map(np.asarray, outcome) for outcome in outcomes)
    alive = 1.0 - 0.16
    # step 1: env 2 failed: terminated, with zero reward and zero reward terms
    np.testing.assert_allclose(first.reward, [alive, alive, 0.0, alive], rtol=1e-6)
    np.testing.assert_allclose(first.reward_terms["ctrl"], [-0.16, -0.16, 0.0, -0.16], rtol=1e-6)
    assert first.terminated.tolist() == [False, False, True, False] and not first.truncated.any()
    assert first.episode.done.tolist() == [False, False, True, False]
    assert first.episode.return_[2] == 0.0 and first.episode.length[2] == 1
    # step 2: env 1 falls (the task's termination: no alive reward); env 2 is one step into its next episode
    np.testing.assert_allclose(second.reward, [alive, -0.16, alive, alive], rtol=1e-6)
    assert second.episode.done.tolist() == [False, True, False, False]
    np.testing.assert_allclose(second.episode.return_[1], alive - 0.16, rtol=1e-6)
    np.testing.assert_allclose(second.episode.reward_terms["alive"][1], 1.0)
    assert second.episode.length[1] == 2 and second.episode.metrics["up"][1] == 0.0
    # step 3: env 0 reaches the length (truncated); env 3 falls on that same step: terminated, not truncated
    assert third.truncated.tolist() == [True, False, False, False]
    assert third.terminated.tolist() == [False, False, False, True]
    assert third.episode.done.tolist() == [True, False, False, True]
    np.testing.assert_allclose(third.episode.return_[[0, 3]], [3 * alive, 2 * alive - 0.16], rtol=1e-6)
    np.testing.assert_allclose(third.episode.reward_terms["ctrl"][0], -0.48, rtol=1e-6)
    assert third.episode.length[[0, 3]].tolist() == [3, 3]
    # the running sums restart where an episode ended, and go on elsewhere
    np.testing.assert_allclose(third.sums.return_, [0.0, alive, 2 * alive, 0.0], rtol=1e-6)
    np.testing.assert_allclose(third.sums.reward_terms["alive"], [0.0, 1.0, 2.0, 0.0])


def test_bookkeeping_on_numpy(task: Task) -> None:
    outcomes = run(task, np, np.float64)
    check(outcomes)
    assert outcomes[0].reward.dtype == np.float64


def test_bookkeeping_inside_jax_jit_matches_numpy(task: Task) -> None:
    outcomes = run(task, jnp, jnp.float32)
    check(outcomes)
    assert outcomes[0].reward.dtype == np.float32
    for ours, reference in zip(outcomes, run(task, np, np.float64), strict=True):
        for got, expected in zip(jax.tree.leaves(ours), jax.tree.leaves(reference), strict=True):
            np.testing.assert_allclose(np.asarray(got, np.float64), np.asarray(expected, np.float64), rtol=1e-6)
