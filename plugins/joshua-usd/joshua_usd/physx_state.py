"""PhysX's state in MuJoCo's layout and MuJoCo's cfrc_ext from PhysX's contact sums: pure functions on numpy or
jax.numpy (`xp`), shared by the NUMPY PhysX environments (`joshua_usd.physx`) and the JAX ones
(`joshua_usd.physx_jax`). Where cfrc_ext's definition comes from: `joshua_usd.physx_contacts`."""

from __future__ import annotations

from typing import Any

import numpy as np


def to_physx(
    xp: Any, qpos: Any, qvel: Any, offsets: Any, qadr: Any, vadr: Any, limits: Any
) -> tuple[Any, Any, Any, Any]:
    """MuJoCo-layout state (N, nq), (N, nv) as PhysX's root pose (N, 7: position in the world, quaternion
    x, y, z, w), root velocity (N, 6: linear, then angular in the world frame), joint positions (held inside
    `limits`, N, dofs, 2) and joint velocities in PhysX's columns; numpy or jax.numpy (`xp`)."""
    quat = qpos[:, 3:7]
    pose = xp.concatenate([qpos[:, :3] + offsets, quat[:, 1:], quat[:, :1]], axis=1)
    velocity = xp.concatenate([qvel[:, :3], rotate(xp, quat, qvel[:, 3:6])], axis=1)
    position = xp.clip(qpos[:, qadr], limits[..., 0], limits[..., 1])
    return pose, velocity, position, qvel[:, vadr]


def from_physx(
    xp: Any, qpos: Any, qvel: Any, pose: Any, velocity: Any, position: Any, dof_velocity: Any, offsets: Any,
    qadr: Any, vadr: Any,
) -> tuple[Any, Any]:  # fmt: skip
    """`to_physx` inverted: `qpos`, `qvel` with PhysX's state written over them (the root's angular velocity in its
    own frame, as MuJoCo's free joint has it)."""
    quat = xp.concatenate([pose[:, 6:7], pose[:, 3:6]], axis=1)
    root = xp.concatenate([pose[:, :3] - offsets, quat], axis=1)
    angular = rotate(xp, quat * xp.asarray([1.0, -1.0, -1.0, -1.0]), velocity[:, 3:])
    if xp is np:
        qpos, qvel = qpos.copy(), qvel.copy()
        qpos[:, :7], qpos[:, qadr] = root, position
        qvel[:, :3], qvel[:, 3:6], qvel[:, vadr] = velocity[:, :3], angular, dof_velocity
        return qpos, qvel
    qpos = qpos.at[:, :7].set(root.astype(qpos.dtype)).at[:, qadr].set(position.astype(qpos.dtype))
    qvel = qvel.at[:, :3].set(velocity[:, :3].astype(qvel.dtype)).at[:, 3:6].set(angular.astype(qvel.dtype))
    return qpos, qvel.at[:, vadr].set(dof_velocity.astype(qvel.dtype))


def robot_com(xp: Any, xpos: Any, xquat: Any, ipos: Any, mass: Any) -> Any:
    """(N, 3) centre of mass of each robot from its links' poses (N, links, 3 and 4, w-first) and their inertial
    offsets and masses (MuJoCo's body_ipos, body_mass of the links: (links,), or (N, links) where each robot has its
    own)."""
    envs, links = xpos.shape[:2]
    offset = xp.broadcast_to(ipos, xpos.shape).reshape(-1, 3)
    xipos = xpos + rotate(xp, xquat.reshape(-1, 4), offset).reshape(envs, links, 3)
    return (xipos * mass[..., None]).sum(axis=-2) / mass.sum(axis=-1)[..., None]


def contact_wrench(xp: Any, normal: Any, friction: Any, sums: Any, centre: Any) -> Any:
    """(N, links, 6) cfrc_ext [torque; force] of each link (see the module docstring) from `ContactReader.read`'s
    arrays, reshaped (N, links, ...), and each robot's centre of mass relative to its lane (N, 3)."""
    centre = centre[:, None, :]
    moment, force, weighted, weight = sums[..., :3], sums[..., 3:6], sums[..., 6:9], sums[..., 9:]
    pressed = weight > 0
    contact_centre = weighted / xp.where(pressed, weight, 1.0) - centre
    torque = moment - xp.cross(centre, force) + xp.where(pressed, xp.cross(contact_centre, friction), 0.0)
    return xp.concatenate([torque, normal + friction], axis=-1)


def rotate(xp: Any, quat: Any, vector: Any) -> Any:
    """Rotate (N, 3) vectors by (N, 4) w-first unit quaternions, on numpy or jax.numpy (`xp`)."""
    w, u = quat[:, :1], quat[:, 1:]
    return vector + 2.0 * xp.cross(u, xp.cross(u, vector) + w * vector)
