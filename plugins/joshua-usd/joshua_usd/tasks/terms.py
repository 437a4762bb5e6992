"""Terms of Isaac's locomotion tasks (IsaacGymEnvs / Isaac Lab `Ant`, `locomotion_env`), on the root free joint.

Isaac describes the robot by its root body's pose and velocity in a frame that turns with it, and
rewards walking towards a target far away along +x (1000 m). Each quantity here is one such term;
all take the root free `joint` (its qpos: x, y, z, qw, qx, qy, qz; its qvel: the world linear
velocity, then the angular velocity in the body frame, as MuJoCo defines them) and run on numpy
and in `jax.jit` alike.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from joshua_core.tasks import Joint, Joints, TermContext

FAR_TARGET = (1000.0, 0.0)  # Isaac's walk target: x, y in m


def _quat(ctx: TermContext, joint: Joint) -> Any:
    """(N, 4) orientation (w, x, y, z) of the free joint's body."""
    return ctx.qpos[:, joint.qpos_adr + 3 : joint.qpos_adr + 7]


def _rotate_inverse(ctx: TermContext, quat: Any, vector: Any) -> Any:
    """`vector` (N, 3) in world coordinates expressed in the frame of `quat` (Isaac's quat_rotate_inverse)."""
    xp = ctx.xp
    w, axis = quat[:, :1], quat[:, 1:]
    dot = xp.sum(axis * vector, axis=1, keepdims=True)
    return vector * (2.0 * w * w - 1.0) - 2.0 * w * xp.cross(axis, vector) + 2.0 * axis * dot


def _wrap(ctx: TermContext, angle: Any) -> Any:
    """The angle in (-pi, pi]."""
    return ctx.xp.arctan2(ctx.xp.sin(angle), ctx.xp.cos(angle))


def _yaw(ctx: TermContext, quat: Any) -> Any:
    w, x, y, z = quat[:, 0], quat[:, 1], quat[:, 2], quat[:, 3]
    return ctx.xp.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _target_distance(ctx: TermContext, qpos: Any, joint: Joint, target: Sequence[float]) -> Any:
    """Horizontal distance of the root from the target, (N,)."""
    dx = target[0] - qpos[:, joint.qpos_adr]
    dy = target[1] - qpos[:, joint.qpos_adr + 1]
    return ctx.xp.sqrt(dx * dx + dy * dy)


def base_lin_vel(ctx: TermContext, joint: Joint) -> Any:
    """Linear velocity of the root in its own frame, (N, 3) (Isaac's vel_loc)."""
    velocity = ctx.qvel[:, joint.dof_adr : joint.dof_adr + 3]
    return _rotate_inverse(ctx, _quat(ctx, joint), velocity)


def base_ang_vel(ctx: TermContext, joint: Joint, scale: float = 1.0) -> Any:
    """Angular velocity of the root in its own frame times `scale`, (N, 3) (Isaac's angvel_loc)."""
    return scale * ctx.qvel[:, joint.dof_adr + 3 : joint.dof_adr + 6]


def yaw_roll(ctx: TermContext, joint: Joint) -> Any:
    """The root's yaw and roll (x-y-z Euler angles, each in (-pi, pi]), (N, 2)."""
    quat = _quat(ctx, joint)
    w, x, y, z = quat[:, 0], quat[:, 1], quat[:, 2], quat[:, 3]
    roll = ctx.xp.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    return ctx.xp.stack([_yaw(ctx, quat), roll], axis=1)


def angle_to_target(ctx: TermContext, joint: Joint, target: Sequence[float] = FAR_TARGET) -> Any:
    """Angle from the root's heading (yaw) to the direction of the target, in (-pi, pi], (N,)."""
    qpos = ctx.qpos
    bearing = ctx.xp.arctan2(target[1] - qpos[:, joint.qpos_adr + 1], target[0] - qpos[:, joint.qpos_adr])
    return _wrap(ctx, bearing - _yaw(ctx, _quat(ctx, joint)))


def heading_projection(ctx: TermContext, joint: Joint, target: Sequence[float] = FAR_TARGET) -> Any:
    """The root's x axis dotted with the unit horizontal direction to the target, (N,) (Isaac's heading_proj)."""
    quat, qpos = _quat(ctx, joint), ctx.qpos
    w, x, y, z = quat[:, 0], quat[:, 1], quat[:, 2], quat[:, 3]
    distance = _target_distance(ctx, qpos, joint, target)
    dx = (target[0] - qpos[:, joint.qpos_adr]) / distance
    dy = (target[1] - qpos[:, joint.qpos_adr + 1]) / distance
    return (1.0 - 2.0 * (y * y + z * z)) * dx + 2.0 * (x * y + w * z) * dy


def heading_reward(
    ctx: TermContext, joint: Joint, target: Sequence[float] = FAR_TARGET, threshold: float = 0.8
) -> Any:
    """1 while the heading projection exceeds `threshold`, else projection / threshold (Isaac's move-to-target)."""
    projection = heading_projection(ctx, joint, target)
    return ctx.xp.where(projection > threshold, 1.0, projection / threshold)


def progress_to_target(ctx: TermContext, joint: Joint, target: Sequence[float] = FAR_TARGET) -> Any:
    """How much closer to the target the root came over the step, per second (Isaac's potential difference)."""
    before = _target_distance(ctx, ctx.prev_qpos, joint, target)
    return (before - _target_distance(ctx, ctx.qpos, joint, target)) / ctx.dt


def energy(ctx: TermContext, joints: Joints = (), vel_scale: float = 0.2) -> Any:  # type: ignore[assignment]
    """Sum over actuated joints of |action x joint velocity x vel_scale| (Isaac's electricity cost).

    `joints` lists the joints in actuator order: action i drives joint i.
    """
    velocities = ctx.qvel[:, np.asarray(joints.dof_index)]
    return ctx.xp.sum(ctx.xp.abs(ctx.action * velocities * vel_scale), axis=1)

