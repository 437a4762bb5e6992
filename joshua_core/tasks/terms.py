"""The built-in task terms. Each is a pure function `term(ctx, **params)` of a `TermContext`.

Observation, reward, metric and termination terms return an array with the environments on the
leading axis: observations (N,) or (N, k), rewards and metrics (N,), terminations (N,) bool.
Reset terms return a new context (`ctx.replace(qpos=...)`) with the state they randomised; the
task applies them in order, so a later reset term sees what an earlier one set.

Written only with `ctx.xp` operations and without in-place writes, so every term runs on numpy and
inside `jax.jit`. Parameters annotated with a handle type (Body, Site, Sensor, Joint, Joints) are
given as names and arrive resolved (see `joshua_core.tasks.handles`). The terms that read a gripper's
touch pads are in `joshua_core.tasks.grasping`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from joshua_core.tasks.context import RandomSource, TermContext, set_columns
from joshua_core.tasks.handles import Actuators, Body, Joint, Joints, Sensor, Site

# --- helpers shared by several terms ----------------------------------------------------------


def _norm(ctx: TermContext, vector: Any) -> Any:
    return ctx.xp.sqrt(ctx.xp.sum(vector * vector, axis=-1))


def _upright(ctx: TermContext, body: Body) -> Any:
    """World z component of the body's z axis, from its quaternion (1 upright, -1 upside down)."""
    quat = ctx.xquat[:, body.id]
    return 1.0 - 2.0 * (quat[:, 1] ** 2 + quat[:, 2] ** 2)


def _normalized(ctx: TermContext, joints: Joints) -> Any:
    """Joint positions mapped linearly from [lower, upper] onto [-1, 1]; ValueError for unlimited joints."""
    lower, upper = np.asarray(joints.lower), np.asarray(joints.upper)
    if not np.isfinite(lower).all() or not np.isfinite(upper).all():
        raise ValueError(f"normalising positions needs limited joints; one of {', '.join(joints.names)} has no range")
    positions = ctx.qpos[:, np.asarray(joints.qpos_index)]
    return (2.0 * positions - upper - lower) / (upper - lower)


def _random(ctx: TermContext) -> RandomSource:
    """The context's random source; reset terms run only where the backend provides one."""
    if ctx.random is None:
        raise ValueError("a reset term needs ctx.random (a RandomSource), which backends set while resetting")
    return ctx.random


def _joint_height_in_range(ctx: TermContext, joint: Joint, min_z: float, max_z: float) -> Any:
    """Whether the free joint's height lies in [min_z, max_z] and the whole state is finite."""
    xp = ctx.xp
    height = ctx.qpos[:, joint.qpos_adr + 2]
    finite = xp.all(xp.isfinite(ctx.qpos), axis=1) & xp.all(xp.isfinite(ctx.qvel), axis=1)
    return finite & (height >= min_z) & (height <= max_z)


# --- observations -----------------------------------------------------------------------------


def qpos(ctx: TermContext, start: int = 0) -> Any:
    """Generalized positions from index `start` (Ant: start=2 hides the torso's x, y)."""
    return ctx.qpos[:, start:]


def qvel(ctx: TermContext, start: int = 0) -> Any:
    """Generalized velocities from index `start`."""
    return ctx.qvel[:, start:]


def joint_pos(ctx: TermContext, joints: Joints = ()) -> Any:  # type: ignore[assignment]
    """Positions of the named joints (empty: every hinge and slide joint)."""
    return ctx.qpos[:, np.asarray(joints.qpos_index)]


def joint_vel(ctx: TermContext, joints: Joints = (), scale: float = 1.0) -> Any:  # type: ignore[assignment]
    """Velocities of the named joints (empty: every hinge and slide joint) times `scale`."""
    return scale * ctx.qvel[:, np.asarray(joints.dof_index)]


def joint_pos_normalized(ctx: TermContext, joints: Joints = ()) -> Any:  # type: ignore[assignment]
    """Positions of the named (limited) joints scaled to [-1, 1] within their limits (Isaac's `unscale`)."""
    return _normalized(ctx, joints)


def contact_forces(ctx: TermContext, limit: float = 1.0) -> Any:
    """External wrenches of every body but the world, clipped to [-limit, limit], flattened (Ant-v5)."""
    forces = ctx.xp.clip(ctx.cfrc_ext[:, 1:], -limit, limit)
    return forces.reshape(forces.shape[0], -1)


def body_contact_force(ctx: TermContext, body: Body, scale: float = 1.0) -> Any:
    """External (contact) wrench on one body, torque then force, times `scale`, (N, 6) (a foot's force sensor)."""
    return scale * ctx.cfrc_ext[:, body.id]


def body_height(ctx: TermContext, body: Body) -> Any:
    """Height of a body's origin above z = 0, (N,)."""
    return ctx.xpos[:, body.id, 2]


def body_pos(ctx: TermContext, body: Body) -> Any:
    """World position of a body, (N, 3)."""
    return ctx.xpos[:, body.id]


def site_pos(ctx: TermContext, site: Site) -> Any:
    """World position of a site, (N, 3)."""
    return ctx.site_xpos[:, site.id]


def command(ctx: TermContext, name: str) -> Any:
    """A per-environment command of the task (e.g. the reach target), as sampled at reset."""
    return ctx.commands[name]


def site_to_command(ctx: TermContext, site: Site, name: str) -> Any:
    """Vector from a site to a position command, (N, 3)."""
    return ctx.commands[name] - ctx.site_xpos[:, site.id]


def site_to_body(ctx: TermContext, site: Site, body: Body) -> Any:
    """Vector from a site to a body, (N, 3)."""
    return ctx.xpos[:, body.id] - ctx.site_xpos[:, site.id]


def body_to_command(ctx: TermContext, body: Body, name: str) -> Any:
    """Vector from a body to a position command, (N, 3)."""
    return ctx.commands[name] - ctx.xpos[:, body.id]


def last_action(ctx: TermContext) -> Any:
    """The action of this step (clipped to [-1, 1])."""
    return ctx.action


def servo_error(ctx: TermContext, actuators: Actuators = ()) -> Any:  # type: ignore[assignment]
    """Each position servo's target minus its joint's position (ctrl - qpos; empty: every actuator): where the
    targets are, which a policy with delta actions moves and must see."""
    return ctx.ctrl[:, np.asarray(actuators.ids)] - ctx.qpos[:, np.asarray(actuators.qpos_index)]


def sensor(ctx: TermContext, sensor: Sensor, saturation: float | None = None) -> Any:
    """Readings of one sensor, (N, dim); with `saturation`, `saturation * tanh(reading / saturation)`: about the
    reading well inside that range, never beyond it, as a real sensor's range ends. A contact force is unbounded
    in simulation (MJX's pick-and-place pads read ~46 N in a grasp and up to 87 kN when the jaw presses the cube
    into the table), and such rare spikes, unsaturated, inflate the observation normaliser's variance until a
    grasp's reading normalises to almost nothing."""
    reading = ctx.sensordata[:, sensor.index]
    if saturation is None:
        return reading
    if not (math.isfinite(saturation) and saturation > 0):
        raise ValueError(f"saturation must be a positive finite number, got {saturation}")
    return saturation * ctx.xp.tanh(reading / saturation)


def body_upright(ctx: TermContext, body: Body) -> Any:
    """How upright a body is: the world z of its z axis (1 upright, 0 on its side, -1 upside down)."""
    return _upright(ctx, body)


# --- rewards and metrics ----------------------------------------------------------------------


def forward_velocity(ctx: TermContext, joint: Joint, axis: int = 0) -> Any:
    """Velocity of a free joint along world `axis`, from its displacement over the step (Gymnasium's Ant)."""
    column = joint.qpos_adr + axis
    return (ctx.qpos[:, column] - ctx.prev_qpos[:, column]) / ctx.dt


def healthy(ctx: TermContext, joint: Joint, min_z: float, max_z: float) -> Any:
    """1 while the free joint's height is in [min_z, max_z] and the state is finite, else 0."""
    return _joint_height_in_range(ctx, joint, min_z, max_z).astype(ctx.qpos.dtype)


def alive(ctx: TermContext) -> Any:
    """1 on every step: a bonus for staying alive, so that episodes which end early collect less."""
    return ctx.xp.ones(ctx.num_envs, ctx.qpos.dtype)


def action_l2(ctx: TermContext) -> Any:
    """Sum of squared actions (Gymnasium's control cost with a negative weight)."""
    return ctx.xp.sum(ctx.action * ctx.action, axis=1)


def action_rate_l2(ctx: TermContext) -> Any:
    """Sum of squared changes of the action since the previous step."""
    change = ctx.action - ctx.prev_action
    return ctx.xp.sum(change * change, axis=1)


def joint_vel_l2(ctx: TermContext, joints: Joints = ()) -> Any:  # type: ignore[assignment]
    """Sum of squared velocities of the named joints (empty: every hinge and slide joint)."""
    velocities = ctx.qvel[:, np.asarray(joints.dof_index)]
    return ctx.xp.sum(velocities * velocities, axis=1)


def contact_force_l2(ctx: TermContext, limit: float = 1.0) -> Any:
    """Sum of squared external wrenches clipped to [-limit, limit] (Gymnasium's contact cost)."""
    forces = ctx.xp.clip(ctx.cfrc_ext, -limit, limit)
    return ctx.xp.sum(forces * forces, axis=(1, 2))


def body_upright_above(ctx: TermContext, body: Body, min_upright: float = 0.93) -> Any:
    """1 while the body's uprightness (see body_upright) exceeds `min_upright`, else 0 (Isaac's up reward)."""
    return (_upright(ctx, body) > min_upright).astype(ctx.xquat.dtype)


def joints_near_upper_limit(ctx: TermContext, joints: Joints = (), threshold: float = 0.98) -> Any:  # type: ignore[assignment]
    """How many of the named joints are past `threshold` of their range towards the upper limit
    (normalised position above it; Isaac's joints-at-limit cost counts only this side)."""
    return ctx.xp.sum(_normalized(ctx, joints) > threshold, axis=1).astype(ctx.qpos.dtype)


def body_height_above(ctx: TermContext, body: Body, height: float) -> Any:
    """1 while the body's origin is higher than `height` (a lifted object), else 0."""
    return (ctx.xpos[:, body.id, 2] > height).astype(ctx.xpos.dtype)


def site_command_distance(ctx: TermContext, site: Site, name: str) -> Any:
    """Distance in m from a site to a position command."""
    return _norm(ctx, site_to_command(ctx, site, name))


def site_command_tanh(ctx: TermContext, site: Site, name: str, std: float = 0.1) -> Any:
    """1 - tanh(distance / std) from a site to a position command: near 1 only when close."""
    return 1.0 - ctx.xp.tanh(site_command_distance(ctx, site, name) / std)


def site_body_tanh(ctx: TermContext, site: Site, body: Body, std: float = 0.1) -> Any:
    """1 - tanh(distance / std) from a site to a body (reaching an object)."""
    return 1.0 - ctx.xp.tanh(_norm(ctx, site_to_body(ctx, site, body)) / std)


def body_command_distance(ctx: TermContext, body: Body, name: str) -> Any:
    """Distance in m from a body to a position command."""
    return _norm(ctx, body_to_command(ctx, body, name))


def body_command_tanh(ctx: TermContext, body: Body, name: str, std: float = 0.1) -> Any:
    """1 - tanh(distance / std) from a body to a position command (an object to its goal)."""
    return 1.0 - ctx.xp.tanh(body_command_distance(ctx, body, name) / std)


def carried_command_tanh(ctx: TermContext, body: Body, name: str, height: float, std: float = 0.1) -> Any:
    """`body_command_tanh` while the body is above `height` (an object carried to its goal), else 0: no reward
    for an object lying near its goal, which would pay a policy for leaving it alone."""
    return body_command_tanh(ctx, body, name, std) * body_height_above(ctx, body, height)


def pushed_command_tanh(ctx: TermContext, site: Site, body: Body, name: str, radius: float, std: float = 0.1) -> Any:
    """`body_command_tanh` while the site is within `radius` m of the body (an object the gripper moves to its
    goal, carried or pushed), else 0: an object left lying near its goal earns nothing."""
    near = _norm(ctx, site_to_body(ctx, site, body)) < radius
    return body_command_tanh(ctx, body, name, std) * near.astype(ctx.xpos.dtype)


def free_body_command_progress(ctx: TermContext, joint: Joint, name: str) -> Any:
    """Speed in m/s at which a free joint's body closes on a position command over the step (negative moving
    away): the change of a potential, -distance (Ng et al., 1999), so it pays for moving an object toward its
    goal as it moves, without changing which policy is best."""
    goal, columns = ctx.commands[name], slice(joint.qpos_adr, joint.qpos_adr + 3)
    return (_norm(ctx, goal - ctx.prev_qpos[:, columns]) - _norm(ctx, goal - ctx.qpos[:, columns])) / ctx.dt


def body_command_within(ctx: TermContext, body: Body, name: str, radius: float) -> Any:
    """1 where a body is within `radius` m of a position command (a success flag), else 0."""
    return (body_command_distance(ctx, body, name) < radius).astype(ctx.xpos.dtype)


# --- terminations -----------------------------------------------------------------------------


def unhealthy(ctx: TermContext, joint: Joint, min_z: float, max_z: float) -> Any:
    """True when the free joint's height leaves [min_z, max_z] or the state is not finite."""
    return ~_joint_height_in_range(ctx, joint, min_z, max_z)


def body_below(ctx: TermContext, body: Body, height: float) -> Any:
    """True when the body's origin falls below `height` (an object dropped off the table)."""
    return ctx.xpos[:, body.id, 2] < height


def body_tilted(ctx: TermContext, body: Body, min_upright: float) -> Any:
    """True when the body's uprightness (see body_upright) drops below `min_upright`."""
    return _upright(ctx, body) < min_upright


# --- reset (randomisation) terms: return the context with the randomised state --------------


def reset_qpos_uniform(ctx: TermContext, scale: float = 0.1) -> TermContext:
    """Add uniform noise in [-scale, scale] to every generalized position (Gymnasium's Ant reset)."""
    return ctx.replace(qpos=ctx.qpos + _random(ctx).uniform(ctx.qpos.shape, -scale, scale))


def reset_qvel_normal(ctx: TermContext, scale: float = 0.1) -> TermContext:
    """Add `scale` times standard normal noise to every generalized velocity (Gymnasium's Ant reset)."""
    return ctx.replace(qvel=ctx.qvel + scale * _random(ctx).normal(ctx.qvel.shape))


def reset_joints_uniform(ctx: TermContext, joints: Joints = (), scale: float = 0.1) -> TermContext:  # type: ignore[assignment]
    """Add uniform noise in [-scale, scale] to the named joints' positions (empty: hinge and slide joints)."""
    columns = np.asarray(joints.qpos_index)
    noise = _random(ctx).uniform((ctx.num_envs, len(columns)), -scale, scale)
    return ctx.replace(qpos=set_columns(ctx.qpos, columns, ctx.qpos[:, columns] + noise))


def reset_free_joint_xy(
    ctx: TermContext, joint: Joint, low: Sequence[float] = (0.0, 0.0), high: Sequence[float] = (0.0, 0.0)
) -> TermContext:
    """Place a free joint (an object) at a uniform x, y in [low, high]; height and orientation unchanged."""
    columns = np.arange(joint.qpos_adr, joint.qpos_adr + 2)
    position = _random(ctx).uniform((ctx.num_envs, 2), np.asarray(low), np.asarray(high))
    return ctx.replace(qpos=set_columns(ctx.qpos, columns, position))


def sample_command_uniform(ctx: TermContext, name: str, low: Sequence[float], high: Sequence[float]) -> TermContext:
    """Sample the command `name` uniformly in the box [low, high] (one value per component)."""
    value = _random(ctx).uniform((ctx.num_envs, len(low)), np.asarray(low), np.asarray(high))
    return ctx.replace(commands={**ctx.commands, name: value})


BUILTIN_TERMS: dict[str, Callable[..., Any]] = {
    function.__name__: function
    for function in (
        qpos,
        qvel,
        joint_pos,
        joint_vel,
        joint_pos_normalized,
        contact_forces,
        body_contact_force,
        body_height,
        body_pos,
        site_pos,
        command,
        site_to_command,
        site_to_body,
        body_to_command,
        last_action,
        servo_error,
        sensor,
        body_upright,
        forward_velocity,
        healthy,
        alive,
        action_l2,
        action_rate_l2,
        joint_vel_l2,
        contact_force_l2,
        body_upright_above,
        joints_near_upper_limit,
        body_height_above,
        site_command_distance,
        site_command_tanh,
        site_body_tanh,
        body_command_distance,
        body_command_tanh,
        carried_command_tanh,
        pushed_command_tanh,
        free_body_command_progress,
        body_command_within,
        unhealthy,
        body_below,
        body_tilted,
        reset_qpos_uniform,
        reset_qvel_normal,
        reset_joints_uniform,
        reset_free_joint_xy,
        sample_command_uniform,
    )
}
