"""Physics other than MuJoCo's stepping `MjxEnv`'s environments inside its compiled step.

A plugin whose simulator keeps its state on the device (joshua-usd's PhysX) implements `ExternalPhysics`;
`MjxEnv(..., external=...)` then steps the environments with it and keeps everything else as on MJX: the
task's terms on the MuJoCo model of the same robot, start states (MJX-JAX's forward of the reset terms),
autoreset, per-environment randomization, and the kinematics after each step (`mjx.kinematics` of the
positions the external physics gives). So every JAX trainer trains on it unchanged.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import jax

from joshua_mjx.physics import mjx


class ExternalPhysics(ABC):
    """The physics of N environments on one device, called by `MjxEnv` inside `jax.jit` on the whole batch."""

    #: the derived state fields (joshua_core.tasks.DERIVED_FIELDS) it gives besides the kinematic ones, which
    #: MjxEnv recomputes from qpos; a task reading any other is refused when the environments are built
    gives: frozenset[str] = frozenset()
    #: the model fields (joshua_core.tasks.MODEL_FIELDS) it takes per environment; a task randomizing another is
    #: refused when the environments are built
    randomizable: frozenset[str] = frozenset()

    @abstractmethod
    def advance(self, data: mjx.Data, nstep: int, fields: dict[str, jax.Array]) -> mjx.Data:
        """`data` of the N environments after `nstep` physics steps under `data.ctrl`: its qpos and qvel, and the
        cfrc_ext (in `data._impl`) where `gives` has it. `fields`: each environment's randomized model fields
        (N, ...), those of `randomizable` the task randomizes. A pure function of its arguments: MjxEnv's
        autoreset writes start states into `data` between calls."""

    def start(self, data: mjx.Data) -> mjx.Data:
        """New episodes' start states (the reset terms' qpos and qvel in `data`) as this physics takes them, before
        MjxEnv computes their kinematics; by default as they are. PhysX holds joints inside their limits."""
        return data
