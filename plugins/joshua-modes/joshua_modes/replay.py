"""Replaying a trajectory on an engine (MuJoCo's model and data): kinematic (set joint positions) or tracked
(drive the actuators).

A `Replayer` moves the engine to any time of the trajectory with `show(t)`: kinematic replay
interpolates the joint positions linearly and runs mj_forward; tracked replay steps the physics up to
`t` with the position actuators' targets interpolated at each step, and records the tracking error.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from joshua_core.errors import UsageError
from joshua_core.interfaces import Engine
from joshua_core.trajectory import Trajectory

SCALAR_JOINTS = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


def model_joint_names(model: mujoco.MjModel) -> list[str]:
    """Names of the model's hinge and slide joints: the joints a trajectory column can name."""
    return [model.joint(j).name for j in range(model.njnt) if model.jnt_type[j] in SCALAR_JOINTS]


def model_joint_ranges(model: mujoco.MjModel) -> dict[str, tuple[float, float]]:
    """Each scalar joint's (low, high) range, (-inf, inf) when unlimited: what a trajectory source maps onto."""
    return {
        model.joint(j).name: (
            (float(model.jnt_range[j, 0]), float(model.jnt_range[j, 1])) if model.jnt_limited[j] else (-np.inf, np.inf)
        )
        for j in range(model.njnt)
        if model.jnt_type[j] in SCALAR_JOINTS
    }


def qpos_addresses(model: mujoco.MjModel, joint_names: tuple[str, ...]) -> NDArray[np.int64]:
    """qpos index of each named (hinge or slide) joint."""
    return np.array([model.jnt_qposadr[model.joint(name).id] for name in joint_names], dtype=np.int64)


def position_actuators(model: mujoco.MjModel, joint_names: tuple[str, ...]) -> NDArray[np.int64]:
    """Id of the position actuator driving each named joint; a joint without one is a UsageError."""
    found = []
    missing = []
    for name in joint_names:
        joint = model.joint(name).id
        candidates = [
            a
            for a in range(model.nu)
            if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT
            and model.actuator_trnid[a, 0] == joint
            and model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE
        ]
        if candidates:
            found.append(candidates[0])
        else:
            missing.append(name)
    if missing:
        raise UsageError(
            f"tracked replay drives each trajectory joint with its position actuator, but "
            f"{', '.join(missing)} {'has' if len(missing) == 1 else 'have'} none; replay kinematically "
            "instead (simulation.replay.tracked=false)"
        )
    return np.array(found, dtype=np.int64)


@dataclass
class TrackingError:
    """Per-joint tracking error of a tracked replay: simulated minus commanded position, at every physics step."""

    joint_names: tuple[str, ...]
    sum_squares: NDArray[np.float64]
    max_abs: NDArray[np.float64]
    samples: int = 0

    def add(self, error: NDArray[np.float64]) -> None:
        self.sum_squares += error * error
        np.maximum(self.max_abs, np.abs(error), out=self.max_abs)
        self.samples += 1

    def summary(self) -> dict[str, dict[str, float]]:
        """{joint: {"rms": ..., "max": ...}} in the joints' units (rad or m)."""
        rms = np.sqrt(self.sum_squares / max(self.samples, 1))
        return {name: {"rms": float(rms[i]), "max": float(self.max_abs[i])} for i, name in enumerate(self.joint_names)}


class Replayer:
    """Moves an engine along the usable rows of a trajectory (`usable`: rows kept after validation)."""

    def __init__(
        self,
        engine: Engine,
        trajectory: Trajectory,
        usable: NDArray[np.bool_] | None = None,
        *,
        tracked: bool = False,
    ) -> None:
        keep = np.ones(trajectory.rows, dtype=bool) if usable is None else usable
        if not keep.any():
            raise UsageError(f"{trajectory.path}: no row can be replayed (every row has a problem; see the report)")
        self.engine = engine
        self.times = trajectory.timestamps[keep]
        self.positions = trajectory.positions[keep]
        self.start_time = float(self.times[0])
        self.end_time = float(self.times[-1])
        self.tracked = tracked
        self._addresses = qpos_addresses(engine.model, trajectory.joint_names)
        self._actuators = position_actuators(engine.model, trajectory.joint_names) if tracked else None
        self._base_qpos = engine.data.qpos.copy()
        self._base_ctrl = engine.data.ctrl.copy()
        self.tracking = TrackingError(
            trajectory.joint_names, np.zeros(len(self._addresses)), np.zeros(len(self._addresses))
        )
        self.restart()

    @property
    def duration(self) -> float:
        return self.end_time - self.start_time

    def pose(self, t: float) -> NDArray[np.float64]:
        """Joint positions at trajectory time `t`, linearly interpolated (held at the ends)."""
        index = int(np.searchsorted(self.times, t, side="right"))
        if index <= 0:
            return self.positions[0]
        if index >= len(self.times):
            return self.positions[-1]
        t0, t1 = self.times[index - 1], self.times[index]
        weight = (t - t0) / (t1 - t0)
        return self.positions[index - 1] + weight * (self.positions[index] - self.positions[index - 1])

    def restart(self) -> None:
        """Back to the first row: joints at its positions, at rest, the actuators (if tracked) aimed at it."""
        data = self.engine.data
        data.qpos[:] = self._base_qpos
        data.qpos[self._addresses] = self.positions[0]
        data.qvel[:] = 0.0
        data.ctrl[:] = self._base_ctrl
        data.time = 0.0
        if self._actuators is not None:
            data.ctrl[self._actuators] = self.positions[0]
        mujoco.mj_forward(self.engine.model, data)

    def show(self, t: float) -> None:
        """Bring the engine to trajectory time `t` (tracked: only forward; earlier times are no-ops)."""
        model, data = self.engine.model, self.engine.data
        if self._actuators is None:
            data.qpos[self._addresses] = self.pose(t)
            data.time = t - self.start_time
            mujoco.mj_forward(model, data)
            return
        timestep = model.opt.timestep
        target = min(t, self.end_time) - self.start_time
        while data.time + 0.5 * timestep <= target:
            data.ctrl[self._actuators] = self.pose(self.start_time + data.time + timestep)
            mujoco.mj_step(model, data)
            self.tracking.add(data.qpos[self._addresses] - self.pose(self.start_time + data.time))
