"""Domain randomization on MJX: per-environment model fields, and the quantities MuJoCo derives from them.

MJX has no `mj_setConst`. Of what it derives from masses, inertias and armature, MJX's physics reads
the inverse weights `body_invweight0` and `dof_invweight0` (they scale the constraint regularisation,
so contacts and joint limits soften with them); `inverse_weights` recomputes them the way
mj_setConst does, at qpos0: A = J M⁻¹ Jᵀ for each body's centre-of-mass Jacobian, and for each
joint's dofs, averaged over the translational and rotational diagonals. Without it a randomized
mass would meet contacts tuned for the old one. (`actuator_acc0` and `body_subtreemass` are derived
too, but MJX reads them only for muscles and sensors that no randomized model here uses.)
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from joshua_core.tasks import INERTIAL_FIELDS, MODEL_FIELDS, Task
from joshua_mjx.engine import put_model
from joshua_mjx.physics import mjx

DERIVED_FIELDS = ("body_invweight0", "dof_invweight0")


class ModelRandomization:
    """Which model fields a task randomizes, and how to make each environment's `mjx.Model` from them."""

    def __init__(self, task: Task, model: mujoco.MjModel, mjx_model: mjx.Model, device: jax.Device) -> None:
        self.mjx_model = mjx_model
        self.fields = tuple(name for name in task.param_fields if name in MODEL_FIELDS)
        self.derives = bool(INERTIAL_FIELDS & set(self.fields))
        self.derives_on_steps = bool(INERTIAL_FIELDS & task.interval_fields)
        if self.derives:  # derived with MJX-JAX's functions (crb, full_m, jac), whichever implementation steps
            self._jax_model = mjx_model if mjx_model.impl == mjx.Impl.JAX else put_model(model, "<model>", device)
            data0 = mjx.make_data(self._jax_model)
            self._data0 = data0.replace(qpos=jnp.asarray(model.qpos0, data0.qpos.dtype))
            self._dof_average = jnp.asarray(_dof_averaging(model))

    def with_derived(self, params: dict[str, jax.Array]) -> dict[str, jax.Array]:
        """`params` (N environments' randomized quantities) with the derived quantities of their models added."""
        if not self.derives:
            return params
        return params | jax.vmap(self.inverse_weights)(self.model_params(params, derived=False))

    def model_params(self, params: dict[str, jax.Array], *, derived: bool = True) -> dict[str, jax.Array]:
        """The per-environment model fields of `params` (with its derived ones), (N, ...) each."""
        names = self.fields + (DERIVED_FIELDS if derived and self.derives else ())
        return {name: params[name].astype(getattr(self.mjx_model, name).dtype) for name in names}

    def model(self, fields: dict[str, jax.Array]) -> mjx.Model:
        """One environment's model: the shared one with its fields (unbatched, inside a vmap)."""
        return self.mjx_model.replace(**fields) if fields else self.mjx_model

    def inverse_weights(self, fields: dict[str, jax.Array]) -> dict[str, jax.Array]:
        """body_invweight0 (nbody, 2) and dof_invweight0 (nv,) of one environment's model, as mj_setConst."""
        m = self._jax_model.replace(**fields)
        d = mjx.crb(m, mjx.com_pos(m, mjx.kinematics(m, self._data0)))
        inverse = jnp.linalg.inv(mjx.full_m(m, d))
        bodies = jnp.arange(m.nbody)
        jacp, jacr = jax.vmap(lambda body: mjx.jac(m, d, d.xipos[body], body))(bodies)  # (nbody, nv, 3)

        def mean_diagonal(jacobian: jax.Array) -> jax.Array:
            return jnp.trace(jacobian.T @ inverse @ jacobian) / 3.0

        body = jnp.stack([jax.vmap(mean_diagonal)(jacp), jax.vmap(mean_diagonal)(jacr)], axis=1)
        body = body.at[0].set(0.0)
        dof = self._dof_average @ jnp.diag(inverse)
        return {
            "body_invweight0": body.astype(m.body_invweight0.dtype),
            "dof_invweight0": dof.astype(m.dof_invweight0.dtype),
        }


def _dof_averaging(model: mujoco.MjModel) -> np.ndarray:
    """(nv, nv): dof_invweight0 = this @ diag(M⁻¹), averaging a free joint's translational and rotational
    dofs and a ball joint's three, as mj_setConst does."""
    average = np.eye(model.nv)
    groups = {int(mujoco.mjtJoint.mjJNT_FREE): (3, 3), int(mujoco.mjtJoint.mjJNT_BALL): (3,)}
    for joint in range(model.njnt):
        start = int(model.jnt_dofadr[joint])
        for size in groups.get(int(model.jnt_type[joint]), ()):
            average[start : start + size, start : start + size] = 1.0 / size
            start += size
    return average
