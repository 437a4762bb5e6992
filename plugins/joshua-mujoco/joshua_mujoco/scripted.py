"""A hand-written pick-and-place controller for the arms' pick-and-place tasks (`so_arm100_pick_place`,
`so101_pick_place`), in the task's own action space.

It proves the task can be solved in a given physics (the backends' tests), and it records demonstrations
(`joshua demos`): from the cube's and the goal's positions it plans
waypoints for the gripper site (above the cube, down, close the jaw, lift, carry, lower, open),
solves each with damped least squares on a CPU copy of the model (the gripper pointing straight down,
its jaw closing along the world x axis, across two faces of the cube) and holds the servo targets for a
fixed number of control steps. Servo targets become actions through the task's own mapping: "offset"
(ctrl = home ctrl + scale * action) or "delta" (ctrl = the targets in force + scale * action, so a target
moves at most `scale` per step and the script's lines are followed at that speed).
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Generator
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from joshua_core.tasks import Task

__all__ = [
    "JAW_CLOSED",
    "JAW_OPEN",
    "Phase",
    "PickPlaceScript",
    "PlannerPool",
    "ScriptPlan",
    "corrected_targets",
    "integrate_sag",
    "pick_place_phases",
]

JAW_OPEN, JAW_CLOSED = 0.8, -0.17  # rad: wide open; the pads' closed angle, so the servo squeezes the cube
ABOVE = 0.08  # m above the cube's centre when approaching and carrying
# The gripper site is the fixed fingertip; the moving pad closes onto it along the site's z axis, so a held
# 3 cm cube's centre is half its width along z from the site.
GRASP_OFFSET = 0.015
# The pads reach 1.7 cm beyond the site (the fingertip points down): gripping 1 cm above the cube's centre
# keeps them off the table.
GRIP_HEIGHT = 0.01
SAG_GAIN = 0.1  # per control step
SAG_LIMIT = 0.1  # rad


@dataclass(frozen=True)
class Phase:
    """One waypoint of a plan: the gripper site's target, the jaw's angle, and how long they are held."""

    name: str
    site: NDArray[np.float64]  # where the gripper site goes (world, m)
    jaw: float
    steps: int  # control steps to hold the targets


def pick_place_phases(cube: NDArray[np.float64], goal: NDArray[np.float64]) -> list[Phase]:
    """The waypoints from the cube's centre to the goal's (both in the world, at the cube's height)."""
    up, grip = np.array([0.0, 0.0, ABOVE]), np.array([0.0, 0.0, GRIP_HEIGHT])
    return [
        Phase("above", cube + up, JAW_OPEN, 40),
        Phase("down", cube + grip, JAW_OPEN, 40),
        Phase("close", cube + grip, JAW_CLOSED, 40),
        Phase("lift", cube + up, JAW_CLOSED, 40),
        Phase("carry", goal + up, JAW_CLOSED, 60),
        Phase("lower", goal + grip, JAW_CLOSED, 40),
        Phase("release", goal + grip, JAW_OPEN, 40),  # and stay: lifting the open jaw away drags the cube along
    ]


@dataclass(frozen=True)
class ScriptPlan:
    """A plan solved for every control step: the phase's name, the arm's joint targets the inverse kinematics gave
    (steps, 5) and the jaw's (steps,). It depends only on where the arm, the cube and the goal start; what the
    servos measure on the way only corrects it (`corrected_targets`, `integrate_sag`)."""

    phases: tuple[str, ...]
    arm: NDArray[np.float64]
    jaw: NDArray[np.float64]

    @property
    def steps(self) -> int:
        return len(self.phases)


def corrected_targets(xp: Any, arm: Any, jaw: Any, sag: Any) -> Any:
    """The servo targets (..., 6) of one step: the planned arm targets (..., 5) plus the sag correction, then the
    jaw's (...). `xp`: numpy or jax.numpy, so that a batch of plans can run inside a compiled rollout."""
    return xp.concatenate([arm + sag, jaw[..., None]], axis=-1)


def integrate_sag(xp: Any, sag: Any, arm: Any, measured: Any) -> Any:
    """The sag correction after a step whose planned arm targets were `arm` and after which the arm's joints are at
    `measured` (both (..., 5)): an integral term that takes out the servos' sag under gravity, which is a few
    centimetres at the far end of the workspace, without winding up while the arm is still moving there."""
    error = arm - measured
    settled = xp.abs(error) < SAG_LIMIT
    return xp.clip(sag + SAG_GAIN * error * settled, -SAG_LIMIT, SAG_LIMIT)


class ScriptPlanner:
    """The script's joint targets for attempts on `model` (a CPU MjModel of the scene being simulated): its
    inverse kinematics, which needs the model alone. The arm's joints are those its actuators drive but the last
    (the jaw's), as both arms order them."""

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self.site = model.site("gripper").id
        joints = [model.joint(int(joint)) for joint in model.actuator_trnid[:-1, 0]]
        self.qpos_addresses = [int(joint.qposadr[0]) for joint in joints]
        self.dofs = [int(joint.dofadr[0]) for joint in joints]

    def plan(
        self,
        qpos: NDArray[np.float64],
        cube: NDArray[np.float64],
        goal: NDArray[np.float64],
        plan: Callable[[NDArray[np.float64], NDArray[np.float64]], list[Phase]] = pick_place_phases,
    ) -> ScriptPlan:
        """The joint targets of every control step of `plan`, the inverse kinematics solved from joint positions
        `qpos` on; `actions` follows them, and a batched rollout can (`ScriptPlan`)."""
        self.data.qpos[:] = qpos  # the IK starts from here and from each solution after
        mujoco.mj_kinematics(self.model, self.data)
        # the jaw closes along +x or -x, whichever the gripper is nearer to now: no half turn of the wrist
        self.across = np.array([np.copysign(1.0, self.data.site_xmat[self.site][2]), 0.0, 0.0])
        start = self._grasp_point()
        names, arms, jaws = [], [], []
        for phase in plan(cube, goal):
            for step in range(phase.steps):
                # the target moves in a straight line over the first half of the phase: no sweeping through the cube
                share = min(1.0, (step + 1) / (phase.steps / 2))
                names.append(phase.name)
                arms.append(self._solve(start + share * (phase.site - start)))
                jaws.append(phase.jaw)
            start = phase.site
        return ScriptPlan(tuple(names), np.array(arms).reshape(-1, len(self.dofs)), np.array(jaws, dtype=np.float64))

    def _grasp_point(self) -> NDArray[np.float64]:
        """Where a held cube's centre is for `self.data`'s joints: GRASP_OFFSET along the site's z axis."""
        mujoco.mj_kinematics(self.model, self.data)
        return self.data.site_xpos[self.site] + GRASP_OFFSET * self.data.site_xmat[self.site].reshape(3, 3)[:, 2]

    def _solve(self, target: NDArray[np.float64]) -> NDArray[np.float64]:
        """Arm joint positions that put the grasp point (between the pads) at `target`, the gripper pointing down
        and its jaw closing along x."""
        model, data = self.model, self.data
        jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        body = model.site_bodyid[self.site]
        for _ in range(200):
            grasp = self._grasp_point()
            mujoco.mj_comPos(model, data)
            frame = data.site_xmat[self.site].reshape(3, 3)
            error = np.concatenate(
                [target - grasp, np.cross(frame[:, 0], [0, 0, -1.0]), np.cross(frame[:, 2], self.across)]
            )
            if np.linalg.norm(error) < 1e-6:
                break
            mujoco.mj_jac(model, data, jacp, jacr, grasp, body)
            jacobian = np.vstack([jacp[:, self.dofs], jacr[:, self.dofs], jacr[:, self.dofs]])
            step = jacobian.T @ np.linalg.solve(jacobian @ jacobian.T + 1e-4 * np.eye(9), error)
            data.qpos[self.qpos_addresses] += step
        return data.qpos[self.qpos_addresses].copy()


class PlannerPool:
    """`ScriptPlanner.plan` of many attempts at once on `workers` processes, each with its own planner of `model`
    (the inverse kinematics is Python and small numpy calls: threads would take turns on the GIL). Spawned, not
    forked: the caller may run JAX, whose threads a fork does not carry."""

    def __init__(self, model: mujoco.MjModel, workers: int) -> None:
        self._pool = ProcessPoolExecutor(
            workers, mp_context=multiprocessing.get_context("spawn"), initializer=_start_planner, initargs=(model,)
        )
        self.workers = workers
        self.qpos_addresses = ScriptPlanner(model).qpos_addresses  # the arm joints', in the plans' column order

    def plans(
        self, qpos: NDArray[np.float64], cubes: NDArray[np.float64], goals: NDArray[np.float64]
    ) -> list[ScriptPlan]:
        """One plan per row of `qpos`, `cubes` and `goals` (as `ScriptPlanner.plan`), in order."""
        chunk = max(1, len(qpos) // (4 * self.workers))  # a few chunks per worker: the attempts' costs differ
        return list(self._pool.map(_plan_attempt, qpos, cubes, goals, chunksize=chunk))

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)


_worker_planner: ScriptPlanner | None = None  # the planner of a PlannerPool's worker process


def _start_planner(model: mujoco.MjModel) -> None:
    """A PlannerPool worker's start: its own planner of `model`."""
    global _worker_planner
    _worker_planner = ScriptPlanner(model)


def _plan_attempt(qpos: NDArray[np.float64], cube: NDArray[np.float64], goal: NDArray[np.float64]) -> ScriptPlan:
    """One attempt's plan, in a PlannerPool worker."""
    assert _worker_planner is not None, "called outside a PlannerPool's worker"
    return _worker_planner.plan(qpos, cube, goal)


class PickPlaceScript(ScriptPlanner):
    """Actions for one environment of the task on `model` (a CPU MjModel of the scene being simulated)."""

    def __init__(self, model: mujoco.MjModel, task: Task) -> None:
        super().__init__(model)
        self.task = task
        self.in_force = task.reset_ctrl(np, 1)[0]  # the targets the servos have, as the environment keeps them

    def actions(
        self,
        qpos: NDArray[np.float64],
        cube: NDArray[np.float64],
        goal: NDArray[np.float64],
        plan: Callable[[NDArray[np.float64], NDArray[np.float64]], list[Phase]] = pick_place_phases,
    ) -> Generator[tuple[str, NDArray[np.float64]], NDArray[np.float64], None]:
        """(phase name, action) for every control step of `plan` (pick and place by default), starting from joint
        positions `qpos`; send the joint positions after each step (they correct the servos' sag)."""
        solved = self.plan(qpos, cube, goal, plan)
        sag = np.zeros(len(self.dofs))
        for phase, arm, jaw in zip(solved.phases, solved.arm, solved.jaw, strict=True):
            measured = yield phase, self._action(corrected_targets(np, arm, jaw, sag))
            sag = integrate_sag(np, sag, arm, measured[self.qpos_addresses])

    def _action(self, targets: NDArray[np.float64]) -> NDArray[np.float64]:
        """The action that brings the servo targets nearest to `targets` in one step."""
        action = self.task.action_for_ctrl(np, targets[None], ctrl=self.in_force[None])[0]
        self.in_force = self.task.action_to_ctrl(np, action[None], ctrl=self.in_force[None])[0]
        return action
