"""The script's plans from `PlannerPool`'s worker processes are the ones `ScriptPlanner` makes in this process,
attempt for attempt and in order."""

from __future__ import annotations

import numpy as np
import pytest

from joshua_core.resources import resolve_data_path
from joshua_mujoco import PlannerPool, compile_model
from joshua_mujoco.scripted import ScriptPlanner

ATTEMPTS = 5
# the same numpy and MuJoCo code on the same machine in another process; a tolerance all the same, far below the
# 1e-6 at which the inverse kinematics stops
PLAN_TOL = 1e-9


@pytest.mark.slow
def test_the_pools_plans_are_the_planners_in_order() -> None:
    model = compile_model(resolve_data_path("so_arm100/pick_place_mjx.xml"))
    rng = np.random.default_rng(0)
    qpos = np.tile(model.qpos0, (ATTEMPTS, 1))
    x, y = rng.uniform(0.15, 0.25, ATTEMPTS), rng.uniform(-0.1, 0.1, ATTEMPTS)
    cubes = np.column_stack([x, y, np.full(ATTEMPTS, 0.015)])
    goals = cubes + [0.0, 0.12, 0.0]
    pool = PlannerPool(model, workers=2)
    try:
        pooled = pool.plans(qpos, cubes, goals)
    finally:
        pool.close()
    planner = ScriptPlanner(model)
    assert pool.qpos_addresses == planner.qpos_addresses
    for i, plan in enumerate(pooled):
        here = planner.plan(qpos[i], cubes[i], goals[i])
        assert plan.phases == here.phases
        np.testing.assert_allclose(plan.arm, here.arm, atol=PLAN_TOL)
        np.testing.assert_allclose(plan.jaw, here.jaw, atol=PLAN_TOL)
    # the attempts differ, so a pool that mixed up their order would fail above
    assert np.abs(pooled[0].arm - pooled[1].arm).max() > 0.05
