"""PhysX physics for the `usd` backend's JAX environments: every JAX trainer trains on PhysX unchanged.

joshua-mjx's `MjxEnv` keeps the task's terms, start states, autoreset and randomization in JAX
(`joshua_mjx.ExternalPhysics`); each physics step is one call from the compiled program into PhysX through
Warp's JAX FFI (`warp.jax_callable`): the call's arguments and results are JAX's own buffers, seen by Warp as
arrays on the same device, which PhysX's tensor bindings read and write. On a GPU the scene runs DirectGPU, so
the state goes from JAX to PhysX and back without host copies; on the CPU the same code runs CPU PhysX.

Each call is given the whole state (root pose and velocity, joint positions and velocities) and the joint
efforts, steps once and gives the state back; the conversions between MuJoCo's layout and PhysX's and MuJoCo's
actuator law run in JAX around it (`joshua_usd.physx_state`, shared with the NUMPY environments). Being given
the whole state makes the call a function of its arguments, as a compiled program needs: the autoreset's start
states, an evaluation's own environments, a rollout replayed, all reach PhysX without bookkeeping. PhysX is
written only the environments whose given state is not the one it holds (a write resets its contact caches,
and with them the friction carried from step to step). The last step of an environment step also reads the
contact report into cfrc_ext (`joshua_usd.physx_contacts`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import warp as wp

from joshua_mjx import ExternalPhysics
from joshua_usd.physx import PhysxScene
from joshua_usd.physx_contacts import SUMS, ContactReader
from joshua_usd.physx_state import contact_wrench, from_physx, robot_com, to_physx

UNHELD = 1e30
# relative difference above which a given state is another than the one PhysX holds: well above float32 rounding of
# the conversions between MuJoCo's layout and PhysX's (the root's angular velocity is rotated there and back),
# well below what a reset or another rollout changes
CHANGED = 1e-6


@wp.kernel
def _changed(
    given: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
    held: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
    mask: wp.array(dtype=wp.uint8),  # type: ignore[valid-type]
) -> None:
    """mask[env] = 1 where an element of its row of `given` differs from `held`."""
    env, column = wp.tid()  # type: ignore[misc]  # a 2-d launch gives two indices
    if wp.abs(given[env, column] - held[env, column]) > CHANGED * (1.0 + wp.abs(held[env, column])):
        mask[env] = wp.uint8(1)


class PhysxJaxPhysics(ExternalPhysics):
    """`num_envs` clones of the stage's robot in one PhysX scene, stepped from JAX on `device` (see the module
    docstring). It gives cfrc_ext and takes the actuators' gains and biases (MuJoCo's actuator law runs in JAX) and
    the links' masses (`_Masses`) per environment; the kinematic fields MjxEnv computes from the positions."""

    gives = frozenset({"cfrc_ext"})
    # body_inertia as joshua_core's randomize_body_mass scales it, by the mass's factor: PhysX's inertia tensor
    # (in its own principal frame) is scaled by the same factor
    randomizable = frozenset({"actuator_gainprm", "actuator_biasprm", "body_mass", "body_inertia"})

    def __init__(
        self, model: mujoco.MjModel, stage_path: Path, num_envs: int, contacts: bool, masses: bool, device: Any
    ) -> None:
        on_gpu = device.platform in ("gpu", "cuda")
        self.scene = scene = PhysxScene(model, stage_path, num_envs, contacts, direct_gpu=on_gpu)
        self.model = model
        self.num_envs = num_envs
        self._device = f"cuda:{device.local_hardware_id}" if on_gpu else "cpu"
        self._offsets = jnp.asarray(scene.offsets, jnp.float32)
        self._limits = jnp.asarray(scene.limits, jnp.float32)
        self._contacts = ContactReader(scene, self._device) if contacts else None
        links, dofs = len(scene.bodies), len(scene.vadr)
        self._dims = {
            "out_pose": (num_envs, 7),
            "out_velocity": (num_envs, 6),
            "out_position": (num_envs, dofs),
            "out_dof_velocity": (num_envs, dofs),
        }
        self._contact_dims = {
            "out_links": (num_envs, links, 7),
            "out_normal": (num_envs * links, 3),
            "out_friction": (num_envs * links, 3),
            "out_sums": (num_envs * links, SUMS),
        }
        self._state_bindings = (scene.root_pose, scene.root_velocity, scene.dof_position, scene.dof_velocity)
        # the state PhysX holds, as the last call read it: a call writes only the environments whose given state
        # differs (autoreset's start states, another rollout's), since a write resets PhysX's contact caches and
        # the friction they carry between steps. Far from any state at first, so the first call writes them all.
        self._held = tuple(
            wp.full(shape, UNHELD, dtype=wp.float32, device=self._device) for shape in self._dims.values()
        )
        self._mask = wp.zeros(num_envs, dtype=wp.uint8, device=self._device)
        self._masses = _Masses(scene, model) if masses else None
        self._step, self._contact_step = self._callables()
        self._ipos = jnp.asarray(model.body_ipos[scene.bodies])

    def advance(self, data: Any, nstep: int, fields: dict[str, jax.Array]) -> Any:
        scene, qpos, qvel = self.scene, data.qpos, data.qvel
        gain, bias = fields.get("actuator_gainprm"), fields.get("actuator_biasprm")
        # each environment's link masses where they are randomized (else the model's, which the call leaves be)
        mass = fields.get(
            "body_mass", jnp.broadcast_to(jnp.asarray(self.model.body_mass), (self.num_envs, self.model.nbody))
        )
        mass = mass[:, scene.bodies].astype(jnp.float32)
        for i in range(nstep):  # frame_skip: a few calls, unrolled
            effort = scene.effort(jnp, data.ctrl, qpos, qvel, gain, bias).astype(jnp.float32)
            state = to_physx(jnp, qpos, qvel, self._offsets, scene.qadr, scene.vadr, self._limits)
            inputs = [x.astype(jnp.float32) for x in state] + [effort, mass]
            if i < nstep - 1 or self._contacts is None:
                pose, velocity, position, dof_velocity = self._step(*inputs, output_dims=self._dims)
            else:
                dims = self._dims | self._contact_dims
                pose, velocity, position, dof_velocity, links, normal, friction, sums = self._contact_step(
                    *inputs, output_dims=dims
                )
            qpos, qvel = from_physx(
                jnp, qpos, qvel, pose, velocity, position, dof_velocity, self._offsets, scene.qadr, scene.vadr
            )
        data = data.replace(qpos=qpos, qvel=qvel)
        if self._contacts is None:
            return data
        n, count = self.num_envs, len(scene.bodies)
        quat = jnp.concatenate([links[..., 6:7], links[..., 3:6]], axis=-1)
        centre = robot_com(jnp, links[..., :3] - self._offsets[:, None], quat, self._ipos, mass)
        normal, friction, sums = (a.reshape(n, count, -1) for a in (normal, friction, sums))
        wrench = contact_wrench(jnp, normal, friction, sums, centre)
        cfrc_ext = data._impl.cfrc_ext.at[:, scene.bodies].set(wrench.astype(data._impl.cfrc_ext.dtype))
        return data.replace(_impl=data._impl.replace(cfrc_ext=cfrc_ext))

    def start(self, data: Any) -> Any:
        """Joint positions held inside PhysX's limits, as PhysX would hold them at its first step."""
        scene = self.scene
        limits = self._limits.astype(data.qpos.dtype)
        held = jnp.clip(data.qpos[:, scene.qadr], limits[..., 0], limits[..., 1])
        return data.replace(qpos=data.qpos.at[:, scene.qadr].set(held))

    def _write_and_step(self, pose: wp.array, velocity: wp.array, position: wp.array, dof_velocity: wp.array,
                        effort: wp.array, mass: wp.array) -> None:  # fmt: skip
        """Write the state of the environments whose state is not what PhysX holds (`_changed`), every
        environment's efforts, and step once. On a GPU, XLA's stream has produced the arrays, and Warp's the mask,
        by the time PhysX (on its own streams) reads them."""
        scene = self.scene
        self._finish()
        state = (pose, velocity, position, dof_velocity)
        self._mask.zero_()
        for given, held in zip(state, self._held, strict=True):
            wp.launch(_changed, dim=given.shape, inputs=[given, held], outputs=[self._mask], device=self._device)
        self._finish()
        for binding, given in zip(self._state_bindings, state, strict=True):
            binding.write(given, mask=self._mask)
        scene.dof_force.write(effort)
        if self._masses is not None:
            self._masses.write(mass.numpy())
        scene.physx.step_sync(float(self.model.opt.timestep))

    def _read(self, pose: wp.array, velocity: wp.array, position: wp.array, dof_velocity: wp.array) -> None:
        """PhysX's state into the call's results, and kept as what PhysX holds."""
        outputs = (pose, velocity, position, dof_velocity)
        for binding, out, held in zip(self._state_bindings, outputs, self._held, strict=True):
            binding.read(out)
            wp.copy(held, out)

    def _callables(self) -> tuple[Any, Any]:
        """The two calls into PhysX, run by XLA through Warp's FFI on the arrays XLA hands over: one step, and one
        step that also reads the link poses and the contact report (None where the task reads no contact
        forces). Warp reads each function's annotations for the arrays' types, so they are plain functions."""

        def physx_step(
            pose: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            velocity: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            position: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            dof_velocity: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            effort: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            mass: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            out_pose: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            out_velocity: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            out_position: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            out_dof_velocity: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
        ) -> None:
            self._write_and_step(pose, velocity, position, dof_velocity, effort, mass)
            self._read(out_pose, out_velocity, out_position, out_dof_velocity)
            self._finish()

        def physx_contact_step(
            pose: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            velocity: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            position: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            dof_velocity: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            effort: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            mass: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            out_pose: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            out_velocity: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            out_position: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            out_dof_velocity: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            out_links: wp.array3d(dtype=wp.float32),  # type: ignore[valid-type]
            out_normal: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            out_friction: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
            out_sums: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
        ) -> None:
            self._write_and_step(pose, velocity, position, dof_velocity, effort, mass)
            self._read(out_pose, out_velocity, out_position, out_dof_velocity)
            self.scene.link_pose.read(out_links)
            assert self._contacts is not None  # this call exists only where the task reads contact forces
            self._contacts.read(out_normal, out_friction, out_sums)
            self._finish()

        mode = wp.JaxCallableGraphMode.NONE  # PhysX's calls synchronize with the host: nothing to capture
        step = wp.jax_callable(physx_step, num_outputs=4, graph_mode=mode, vmap_method=None)
        if self._contacts is None:
            return step, None
        return step, wp.jax_callable(physx_contact_step, num_outputs=8, graph_mode=mode, vmap_method=None)

    def _finish(self) -> None:
        """On a GPU, wait for the work queued on every stream (XLA's, Warp's, PhysX's): PhysX and Warp work on
        streams of their own, ordered with XLA's only by the host."""
        if self._device != "cpu":
            wp.synchronize_device(self._device)

    def close(self) -> None:
        self.scene.close()


class _Masses:
    """Each environment's link masses and inertias in PhysX, written where a call is given masses other than those
    PhysX holds (a new episode's draws). They are PhysX's host-side properties: the masses cross to the host on
    each call (a few bytes per environment), the writes happen at episode starts only."""

    def __init__(self, scene: PhysxScene, model: mujoco.MjModel) -> None:
        from ovphysx.types import TensorType

        self._mass = scene.bind(TensorType.ARTICULATION_BODY_MASS)
        self._inertia = scene.bind(TensorType.ARTICULATION_BODY_INERTIA)
        self._mass0 = np.zeros(self._mass.shape, np.float32)
        self._inertia0 = np.zeros(self._inertia.shape, np.float32)
        self._mass.read(self._mass0)
        self._inertia.read(self._inertia0)
        self._default = model.body_mass[scene.bodies].astype(np.float32)  # what the factors are relative to
        self._held = np.broadcast_to(self._default, self._mass0.shape).copy()

    def write(self, mass: np.ndarray) -> None:
        """Give PhysX `mass` (num_envs, links), MuJoCo's masses of the links: PhysX's own scaled by their factors."""
        changed = (np.abs(mass - self._held) > CHANGED * (1.0 + np.abs(self._held))).any(axis=1)
        if not changed.any():
            return
        factor = mass / self._default
        mask = changed.astype(np.uint8)
        self._mass.write(np.ascontiguousarray(self._mass0 * factor, np.float32), mask=mask)
        inertia = self._inertia0 * factor.reshape(*factor.shape, *(1,) * (self._inertia0.ndim - 2))
        self._inertia.write(np.ascontiguousarray(inertia, np.float32), mask=mask)
        self._held[changed] = mass[changed]


def physx_device_envs(spec: Any, path: Path, task: Any, model: mujoco.MjModel) -> Any:
    """joshua-mjx's MjxEnv of `task` on PhysX (`PhysxJaxPhysics`), on one device of `spec.devices` (default: JAX's
    first)."""
    from joshua_mjx import WARP, MjxEnv, Physics

    # PhysX allocates its GPU memory outside JAX's pool, as MuJoCo Warp does: JAX is to allocate on demand
    Physics(WARP).leave_memory_to_warp()
    devices = list(spec.devices or jax.devices()[:1])
    masses = "body_mass" in task.param_fields
    physics = PhysxJaxPhysics(model, path, spec.num_envs, "cfrc_ext" in task.fields, masses, devices[0])
    deterministic = bool(spec.training is not None and spec.training.deterministic)
    return MjxEnv(
        task,
        model,
        spec.num_envs,
        source=path,
        devices=devices,
        desync_episodes=spec.desync_episodes,
        curriculum=spec.curriculum,
        physics=Physics(deterministic=deterministic),
        external=physics,
    )
