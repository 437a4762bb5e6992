"""Terms of Isaac's locomotion tasks (IsaacGymEnvs / Isaac Lab `Ant`, `locomotion_env`), of the robot's root body.

Isaac describes the robot by its root body's pose and velocity in a frame that turns with it, and
rewards walking towards a target far away along +x (1000 m). Each quantity here is one such term;
all take the root `body` (the floating body; they read its free joint, whatever it is called: its
qpos x, y, z, qw, qx, qy, qz, and its qvel, the world linear velocity, then the angular velocity
in the body frame, as MuJoCo defines them) and run on numpy and in `jax.jit` alike.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from joshua_core.tasks import Actuators, Body, TermContext

FAR_TARGET = (1000.0, 0.0)  # Isaac's walk target: x, y in m


def _free(body: Body) -> tuple[int, int]:
    """The qpos and qvel addresses of the body's free joint; ValueError for a body that has none."""
    if body.free_qpos_adr < 0:
        raise ValueError(f"body '{body.name}' has no free joint: name the robot's floating root body")
    return body.free_qpos_adr, body.free_dof_adr


def _quat(ctx: TermContext, body: Body) -> Any:
    """(N, 4) orientation (w, x, y, z) of the root body."""
    adr = _free(body)[0]
    return ctx.qpos[:, adr + 3 : adr + 7]


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
    """Rotation about world z of the orientation `quat` (the yaw of x-y-z Euler angles), (N,)."""
    w, x, y, z = quat[:, 0], quat[:, 1], quat[:, 2], quat[:, 3]
    return ctx.xp.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _to_target(qpos: Any, body: Body, target: Sequence[float]) -> tuple[Any, Any]:
    """Horizontal vector (x, y) from the root to the target, each (N,)."""
    adr = _free(body)[0]
    return target[0] - qpos[:, adr], target[1] - qpos[:, adr + 1]


def _target_distance(ctx: TermContext, qpos: Any, body: Body, target: Sequence[float]) -> Any:
    """Horizontal distance of the root from the target, (N,)."""
    dx, dy = _to_target(qpos, body, target)
    return ctx.xp.sqrt(dx * dx + dy * dy)


def base_lin_vel(ctx: TermContext, body: Body) -> Any:
    """Linear velocity of the root in its own frame, (N, 3) (Isaac's vel_loc)."""
    adr = _free(body)[1]
    return _rotate_inverse(ctx, _quat(ctx, body), ctx.qvel[:, adr : adr + 3])


def base_ang_vel(ctx: TermContext, body: Body, scale: float = 1.0) -> Any:
    """Angular velocity of the root in its own frame times `scale`, (N, 3) (Isaac's angvel_loc)."""
    adr = _free(body)[1]
    return scale * ctx.qvel[:, adr + 3 : adr + 6]


def yaw_roll(ctx: TermContext, body: Body) -> Any:
    """The root's yaw and roll (x-y-z Euler angles, each in (-pi, pi]), (N, 2)."""
    quat = _quat(ctx, body)
    w, x, y, z = quat[:, 0], quat[:, 1], quat[:, 2], quat[:, 3]
    roll = ctx.xp.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    return ctx.xp.stack([_yaw(ctx, quat), roll], axis=1)


def angle_to_target(ctx: TermContext, body: Body, target: Sequence[float] = FAR_TARGET) -> Any:
    """Angle from the root's heading (yaw) to the direction of the target, in (-pi, pi], (N,)."""
    dx, dy = _to_target(ctx.qpos, body, target)
    return _wrap(ctx, ctx.xp.arctan2(dy, dx) - _yaw(ctx, _quat(ctx, body)))


def heading_projection(ctx: TermContext, body: Body, target: Sequence[float] = FAR_TARGET) -> Any:
    """The root's x axis dotted with the unit horizontal direction to the target, (N,) (Isaac's heading_proj)."""
    quat = _quat(ctx, body)
    w, x, y, z = quat[:, 0], quat[:, 1], quat[:, 2], quat[:, 3]
    dx, dy = _to_target(ctx.qpos, body, target)
    distance = ctx.xp.sqrt(dx * dx + dy * dy)
    return ((1.0 - 2.0 * (y * y + z * z)) * dx + 2.0 * (x * y + w * z) * dy) / distance


def heading_reward(ctx: TermContext, body: Body, target: Sequence[float] = FAR_TARGET, threshold: float = 0.8) -> Any:
    """1 while the heading projection exceeds `threshold`, else projection / threshold (Isaac's move-to-target)."""
    projection = heading_projection(ctx, body, target)
    return ctx.xp.where(projection > threshold, 1.0, projection / threshold)


def progress_to_target(ctx: TermContext, body: Body, target: Sequence[float] = FAR_TARGET) -> Any:
    """How much closer to the target the root came over the step, per second (Isaac's potential difference)."""
    before = _target_distance(ctx, ctx.prev_qpos, body, target)
    return (before - _target_distance(ctx, ctx.qpos, body, target)) / ctx.dt


def energy(ctx: TermContext, actuators: Actuators = (), vel_scale: float = 0.2) -> Any:  # type: ignore[assignment]
    """Sum over actuators of |action x velocity of the driven joint x vel_scale| (Isaac's electricity cost)."""
    velocities = ctx.qvel[:, np.asarray(actuators.dof_index)]
    return ctx.xp.sum(ctx.xp.abs(ctx.action * velocities * vel_scale), axis=1)
