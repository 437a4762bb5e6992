"""What a task term sees: `TermContext`, the batched state of N environments, and random sources.

Terms are pure functions of the context. The context holds arrays whose leading axis is the
environments and the array namespace `xp` (numpy on the CPU, jax.numpy under MJX), so a term
written with `ctx.xp` and without in-place writes runs unchanged on both, including inside
`jax.jit`. Randomness goes through `ctx.random`, a `RandomSource` that each backend provides.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

# The state fields a backend may provide, with their per-environment shapes (names as in MjData).
STATE_FIELDS: dict[str, str] = {
    "qpos": "(nq,) generalized positions",
    "qvel": "(nv,) generalized velocities",
    "prev_qpos": "(nq,) qpos before this step (for displacement-based velocities)",
    "xpos": "(nbody, 3) body frame positions in the world",
    "xquat": "(nbody, 4) body frame orientations (w, x, y, z)",
    "site_xpos": "(nsite, 3) site positions in the world",
    "sensordata": "(nsensordata,) all sensor readings",
    "cfrc_ext": "(nbody, 6) external (contact) wrench on each body, torque then force",
    "ctrl": "(nu,) the actuators' controls in force (servo targets), set from this step's action",
    "action": "(nu,) the policy's action of this step, after clipping to [-1, 1]",
    "prev_action": "(nu,) the action of the previous step (zero after a reset)",
    "episode_step": "() steps taken in the current episode",
}
# The state fields MuJoCo computes from qpos and qvel (kinematics, sensors, contact wrenches) rather than
# integrates: a backend fills only those the task's terms read (`Task.fields`), and only then pays for them.
DERIVED_FIELDS = ("xpos", "xquat", "site_xpos", "sensordata", "cfrc_ext")
# Of them, the body and site poses: every backend recomputes them after the step, so they describe its end.
KINEMATIC_FIELDS = frozenset({"xpos", "xquat", "site_xpos"})


class RandomSource(Protocol):
    """Random numbers for reset terms; each backend supplies one (numpy Generator, JAX key, ...)."""

    def uniform(self, shape: tuple[int, ...], low: Any = 0.0, high: Any = 1.0) -> Any:
        """Samples uniform in [low, high) with the given shape (low/high broadcast against it)."""
        ...

    def normal(self, shape: tuple[int, ...]) -> Any:
        """Standard normal samples with the given shape."""
        ...


class NumpyRandom:
    """A RandomSource over a numpy Generator (the CPU backends)."""

    def __init__(self, generator: np.random.Generator) -> None:
        self.generator = generator

    def uniform(self, shape: tuple[int, ...], low: Any = 0.0, high: Any = 1.0) -> np.ndarray:
        return self.generator.uniform(low, high, size=shape)

    def normal(self, shape: tuple[int, ...]) -> np.ndarray:
        return self.generator.standard_normal(shape)


class JaxRandom:
    """A RandomSource over a JAX key, usable inside `jax.jit`: every draw splits off a fresh subkey.

    The key advances as a Python attribute while the function is traced, so the same call site
    gets independent numbers per draw; pass a fresh key per reset.
    """

    def __init__(self, key: Any) -> None:
        self.key = key

    def _next_key(self) -> Any:
        import jax

        self.key, subkey = jax.random.split(self.key)
        return subkey

    def uniform(self, shape: tuple[int, ...], low: Any = 0.0, high: Any = 1.0) -> Any:
        import jax

        return jax.random.uniform(self._next_key(), shape, minval=low, maxval=high)

    def normal(self, shape: tuple[int, ...]) -> Any:
        import jax

        return jax.random.normal(self._next_key(), shape)


@dataclass(frozen=True)
class TermContext:
    """The batched state a term reads. Every array has the environments on its leading axis.

    Backends fill the fields their task reads (`Task.fields` lists them) and leave the others
    None. `commands` holds per-environment task variables sampled by reset terms, such as the
    reach target; `random` is set while reset terms run.
    """

    xp: Any
    dt: float
    qpos: Any = None
    qvel: Any = None
    prev_qpos: Any = None
    xpos: Any = None
    xquat: Any = None
    site_xpos: Any = None
    sensordata: Any = None
    cfrc_ext: Any = None
    ctrl: Any = None
    action: Any = None
    prev_action: Any = None
    episode_step: Any = None
    commands: Mapping[str, Any] = field(default_factory=dict)
    random: RandomSource | None = None
    # Domain randomization (joshua_core.tasks.randomization): each environment's current values of the
    # randomized quantities, (N, ...) by name, and the model's own values of them, unbatched.
    params: Mapping[str, Any] = field(default_factory=dict)
    defaults: Mapping[str, Any] = field(default_factory=dict)
    # (N,) each environment's strength in [0, 1] of the events it draws (a randomization curriculum); None: full
    strength: Any = None

    @property
    def num_envs(self) -> int:
        """The number of environments in this batch (the leading axis of qpos)."""
        return int(self.qpos.shape[0])

    def replace(self, **changes: Any) -> TermContext:
        """A copy with some fields changed (contexts are immutable, as JAX needs).

        Copies the fields without reading them as attributes, so that `Task.fields` (found by
        watching which attributes terms read) lists only what terms use.
        """
        values = {f.name: object.__getattribute__(self, f.name) for f in dataclasses.fields(self)}
        return type(self)(**{**values, **changes})


def set_columns(array: Any, columns: Any, values: Any) -> Any:
    """`array` with `array[:, columns] = values`, without writing in place (numpy and JAX arrays)."""
    if hasattr(array, "at"):  # a JAX array: functional update
        return array.at[:, columns].set(values)
    updated = np.array(array, copy=True)
    updated[:, columns] = values
    return updated
