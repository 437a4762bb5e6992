"""The physics under `BatchedSimulation`: N copies of one MuJoCo model's state, stepped by some engine.

`BatchedSimulation` (joshua_mujoco.vector) holds the task, the step order, resets and autoreset; it
touches the physics only through `BatchPhysics`. `MuJoCoBatchPhysics` is `mujoco.batch`; another engine
(joshua-usd's PhysX) implements the same few methods and gets the same environments and task terms.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import mujoco
import numpy as np
from mujoco.batch import Batch, SimulationError
from numpy.typing import NDArray

from joshua_core.tasks import KINEMATIC_FIELDS

# Fields that describe the state after the step: mjSTAGE_VEL recomputes kinematics and sensors at its end (as
# mj_step1 would, so the next step reuses them). cfrc_ext is not among them: like Gymnasium, it is the contact
# wrench of the step's last substep.
_CURRENT_FIELDS = KINEMATIC_FIELDS | {"sensordata"}


class BatchPhysics(ABC):
    """`num_envs` simulations of `model`, their state in MuJoCo's layout.

    `field(name)` is a (num_envs, ...) array of one state field (qpos, qvel, ctrl, the derived fields the
    task reads, xfrc_applied) that the caller reads and writes in place: what it writes to qpos, qvel and
    ctrl is taken by the next `forward` or `step`, which then refresh every field they touch.
    """

    model: mujoco.MjModel
    num_envs: int

    @property
    @abstractmethod
    def nthread(self) -> int:
        """Threads stepping the simulations."""

    @abstractmethod
    def field(self, name: str) -> NDArray[np.float64]:
        """The state field `name` of every simulation (see the class docstring)."""

    @abstractmethod
    def model_field(self, name: str) -> NDArray[np.float64]:
        """Each simulation's own copy of the model field `name` (domain randomization), (num_envs, ...)."""

    @abstractmethod
    def set_const(self, ids: NDArray[np.intp]) -> None:
        """Recompute what the simulations `ids` derive from masses and armature, after model_field writes."""

    @abstractmethod
    def reset(self, ids: NDArray[np.intp], keyframe: int | None) -> None:
        """Put the simulations `ids` in the model's initial state (or the keyframe's), without recomputing."""

    @abstractmethod
    def forward(self, ids: NDArray[np.intp]) -> None:
        """Take the written state of the simulations `ids` and recompute their derived fields."""

    @abstractmethod
    def step(self, nstep: int) -> NDArray[np.bool_]:
        """Advance every simulation `nstep` physics steps under its ctrl; return which ones failed."""

    @abstractmethod
    def model_and_data(self, env_index: int) -> tuple[mujoco.MjModel, mujoco.MjData]:
        """One simulation as MuJoCo model and data (its current pose), for drawing it."""

    @abstractmethod
    def close(self) -> None:
        """Release the engine's resources."""


class MuJoCoBatchPhysics(BatchPhysics):
    """`mujoco.batch`: the simulations are MuJoCo's own, their fields live views of them."""

    def __init__(self, model: mujoco.MjModel, num_envs: int, fields: frozenset[str], nthread: int | None) -> None:
        self.model = model
        self.num_envs = num_envs
        self.batch = Batch(model, nsim=num_envs, nthread=nthread or 0)
        # Recompute positions and velocities after each step only when terms read derived fields.
        self.stage = mujoco.mjtStage.mjSTAGE_VEL if _CURRENT_FIELDS & fields else mujoco.mjtStage.mjSTAGE_NONE

    @property
    def nthread(self) -> int:
        return int(self.batch.nthread)

    def field(self, name: str) -> NDArray[np.float64]:
        return self.batch.bind(name)

    def model_field(self, name: str) -> NDArray[np.float64]:
        return self.batch.expand(name)

    def set_const(self, ids: NDArray[np.intp]) -> None:
        self.batch.set_const(ids)

    def reset(self, ids: NDArray[np.intp], keyframe: int | None) -> None:
        self.batch.reset(ids, keyframe=keyframe, stage=mujoco.mjtStage.mjSTAGE_NONE)

    def forward(self, ids: NDArray[np.intp]) -> None:
        self.batch.forward(ids)

    def step(self, nstep: int) -> NDArray[np.bool_]:
        failed = np.zeros(self.num_envs, dtype=bool)
        try:
            self.batch.step(nstep=nstep, stage=self.stage)
        except SimulationError as error:
            failed[error.ids] = True
        return failed

    def model_and_data(self, env_index: int) -> tuple[mujoco.MjModel, mujoco.MjData]:
        model, data = self.batch.get_model(env_index), self.batch.get_data(env_index)
        mujoco.mj_forward(model, data)
        return model, data

    def close(self) -> None:
        """Nothing to release: the batch is freed with this object."""
