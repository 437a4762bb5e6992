"""USD joints from MuJoCo joints, frames consistent with the bodies' world poses at qpos0, and
drives from MuJoCo's actuators."""

from __future__ import annotations

import mujoco
import numpy as np
from pxr import Gf, Sdf, Usd, UsdPhysics

from joshua_core.errors import ModelError
from joshua_usd.exporter.context import Context, per_degree, set_physx, set_raw
from joshua_usd.exporter.frames import WORLD, Pose, axis_frame, gf_quatf, gf_vec3f, quat_mul
from joshua_usd.physx_schema import JOINT_AXES

J = mujoco.mjtJoint


def write_joints(ctx: Context) -> dict[int, Usd.Prim]:
    """One USD joint per MuJoCo body (its joint, or a FixedJoint where it has none; none for a free
    joint: a floating base, whose body keeps the joint's name as joshua:freeJoint).
    Returns the joint prims by MuJoCo joint id."""
    model = ctx.model
    scope = ctx.scope("joints")
    prims: dict[int, Usd.Prim] = {}
    for body in range(1, model.nbody):
        count = model.body_jntnum[body]
        if model.body_mocapid[body] >= 0:
            continue
        if count > 1:
            name = ctx.name(mujoco.mjtObj.mjOBJ_BODY, body, "body")
            raise ModelError(
                f"body '{name}' has {count} joints; USD joints connect two bodies with one joint "
                "each: give each joint its own body"
            )
        if count == 0:
            _fixed_joint(ctx, scope, body)
            continue
        joint = model.body_jntadr[body]
        if model.jnt_type[joint] != J.mjJNT_FREE:
            prims[joint] = _moving_joint(ctx, scope, body, joint)
        elif name := mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, joint):
            prim = ctx.stage.GetPrimAtPath(ctx.body_paths[body])  # USD has no free joint: its name on the body
            set_raw(prim, "joshua:freeJoint", Sdf.ValueTypeNames.String, name, custom=True)
    return prims


def _connect(ctx: Context, joint: UsdPhysics.Joint, body: int, frame: Pose) -> None:
    """Set body0 (the parent; none for the world), body1 and both local frames of a joint whose frame
    is `frame` in body1's frame, so both sides coincide in the world at qpos0."""
    parent = ctx.model.body_parentid[body]
    parent_pose = ctx.body_pose(parent) if parent else WORLD
    if parent:
        joint.CreateBody0Rel().SetTargets([ctx.body_paths[parent]])
    joint.CreateBody1Rel().SetTargets([ctx.body_paths[body]])
    pose = ctx.body_pose(body)
    anchor = pose.apply(frame.pos)
    joint.CreateLocalPos0Attr(gf_vec3f(parent_pose.inverse_apply(anchor)))
    joint.CreateLocalRot0Attr(gf_quatf(parent_pose.relative_quat(quat_mul(pose.quat, frame.quat))))
    joint.CreateLocalPos1Attr(gf_vec3f(frame.pos))
    joint.CreateLocalRot1Attr(gf_quatf(frame.quat))


def _fixed_joint(ctx: Context, scope: Sdf.Path, body: int) -> None:
    name = ctx.name(mujoco.mjtObj.mjOBJ_BODY, body, "body")
    joint = UsdPhysics.FixedJoint.Define(ctx.stage, ctx.child_path(scope, f"{name}_fixed"))
    _connect(ctx, joint, body, WORLD)  # the joint frame is the body frame


def _moving_joint(ctx: Context, scope: Sdf.Path, body: int, joint_id: int) -> Usd.Prim:
    """A revolute (hinge), prismatic (slide) or spherical (ball) joint with its limits (degrees for
    angles, relative to the joint's ref: USD's zero is MuJoCo's qpos0) and PhysX joint properties."""
    model = ctx.model
    kind = model.jnt_type[joint_id]
    path = ctx.child_path(scope, ctx.name(mujoco.mjtObj.mjOBJ_JOINT, joint_id, "joint"))
    ref = model.qpos0[model.jnt_qposadr[joint_id]] if kind != J.mjJNT_BALL else 0.0
    low, high = model.jnt_range[joint_id] - ref
    limited = bool(model.jnt_limited[joint_id])
    if kind == J.mjJNT_BALL:
        joint = UsdPhysics.SphericalJoint.Define(ctx.stage, path)
        frame = Pose(model.jnt_pos[joint_id].copy(), WORLD.quat)
        if limited:
            joint.CreateAxisAttr("X")
            joint.CreateConeAngle0LimitAttr(float(np.degrees(high)))
            joint.CreateConeAngle1LimitAttr(float(np.degrees(high)))
    else:
        token, rotation = axis_frame(model.jnt_axis[joint_id])
        frame = Pose(model.jnt_pos[joint_id].copy(), rotation)
        schema = UsdPhysics.RevoluteJoint if kind == J.mjJNT_HINGE else UsdPhysics.PrismaticJoint
        joint = schema.Define(ctx.stage, path)
        joint.CreateAxisAttr(token)
        if limited:
            scale = np.degrees if kind == J.mjJNT_HINGE else float
            joint.CreateLowerLimitAttr(float(scale(low)))
            joint.CreateUpperLimitAttr(float(scale(high)))
    _connect(ctx, joint, body, frame)
    _joint_properties(ctx, joint.GetPrim(), joint_id)
    return joint.GetPrim()


def _joint_properties(ctx: Context, prim: Usd.Prim, joint_id: int) -> None:
    """Per PhysX axis of the joint (PhysxJointAxisAPI; a ball joint's three rotation axes): armature,
    frictionloss as static and dynamic friction effort and passive damping as viscous friction (per degree on
    angular axes): MuJoCo's meanings exactly."""
    model = ctx.model
    kind = J(int(model.jnt_type[joint_id]))
    angular = kind != J.mjJNT_SLIDE
    for axis, instance in enumerate(JOINT_AXES[kind]):
        dof = model.jnt_dofadr[joint_id] + axis
        friction = float(model.dof_frictionloss[dof])
        damping = float(model.dof_damping[dof])
        values = {
            "armature": float(model.dof_armature[dof]),
            "staticFrictionEffort": friction,
            "dynamicFrictionEffort": friction,
            "viscousFrictionCoefficient": per_degree(damping) if angular else damping,
        }
        for name, value in values.items():
            set_physx(prim, "PhysxJointAxisAPI", name, Sdf.ValueTypeNames.Float, value, instance)
    if model.jnt_stiffness[joint_id]:
        ctx.note(f"joint '{prim.GetName()}': spring stiffness {model.jnt_stiffness[joint_id]:g}")


def write_drives(ctx: Context, joints: dict[int, Usd.Prim]) -> None:
    """A PhysicsDriveAPI per actuated hinge or slide: position actuators as stiffness/damping drives
    (per degree on angular drives) with their force range; motors as effort drives (stiffness and
    damping 0, maxForce the largest torque the motor can give). Anything else becomes a note."""
    model = ctx.model
    driven: set[int] = set()
    for actuator in range(model.nu):
        name = ctx.name(mujoco.mjtObj.mjOBJ_ACTUATOR, actuator, "actuator")
        joint_id = int(model.actuator_trnid[actuator, 0])
        kind = _actuator_kind(model, actuator)
        if model.actuator_trntype[actuator] != mujoco.mjtTrn.mjTRN_JOINT or joint_id not in joints or kind is None:
            ctx.note(f"actuator '{name}': only position and motor actuators on hinge and slide joints are exported")
            continue
        if model.jnt_type[joint_id] == J.mjJNT_BALL or joint_id in driven:
            ctx.note(f"actuator '{name}': a ball joint or a second actuator on one joint is not exported")
            continue
        driven.add(joint_id)
        _drive(ctx, joints[joint_id], actuator, joint_id, kind)
        prim = joints[joint_id]
        set_raw(prim, "joshua:actuator", Sdf.ValueTypeNames.String, name, custom=True)
        set_raw(prim, "joshua:actuator:kind", Sdf.ValueTypeNames.Token, kind, custom=True)
        gear = float(model.actuator_gear[actuator, 0])
        set_raw(prim, "joshua:actuator:gear", Sdf.ValueTypeNames.Float, gear, custom=True)
        if model.actuator_ctrllimited[actuator]:
            ctrl = Gf.Vec2f(*(float(v) for v in model.actuator_ctrlrange[actuator]))
            set_raw(prim, "joshua:actuator:ctrlRange", Sdf.ValueTypeNames.Float2, ctrl, custom=True)


def _actuator_kind(model: mujoco.MjModel, actuator: int) -> str | None:
    """'position' (fixed gain kp, affine bias -kp*q - kv*qdot), 'motor' (fixed gain, no bias), else None."""
    if model.actuator_gaintype[actuator] != mujoco.mjtGain.mjGAIN_FIXED or model.actuator_dyntype[actuator]:
        return None
    gain, bias = model.actuator_gainprm[actuator], model.actuator_biasprm[actuator]
    if model.actuator_biastype[actuator] == mujoco.mjtBias.mjBIAS_NONE:
        return "motor"
    if model.actuator_biastype[actuator] == mujoco.mjtBias.mjBIAS_AFFINE and bias[0] == 0 and bias[1] == -gain[0]:
        return "position"
    return None


def _drive(ctx: Context, prim: Usd.Prim, actuator: int, joint_id: int, kind: str) -> None:
    """The joint torque of a gear-g actuator is g*force, its length g*q: a position servo is a drive
    with stiffness g^2*kp, damping g^2*kv and target ctrl/g (relative to the joint's qpos0)."""
    model = ctx.model
    angular = model.jnt_type[joint_id] == J.mjJNT_HINGE
    drive = UsdPhysics.DriveAPI.Apply(prim, "angular" if angular else "linear")
    drive.CreateTypeAttr("force")
    gear = float(model.actuator_gear[actuator, 0])
    limit = _effort_limit(model, actuator, kind)
    if np.isfinite(limit):
        drive.CreateMaxForceAttr(limit)
    if kind == "motor":
        drive.CreateStiffnessAttr(0.0)
        drive.CreateDampingAttr(0.0)
        return
    kp, kv = model.actuator_gainprm[actuator, 0], 0.0 - model.actuator_biasprm[actuator, 2]  # 0.0 - : no -0 in the file
    ctrl = np.clip(0.0, *model.actuator_ctrlrange[actuator]) if model.actuator_ctrllimited[actuator] else 0.0
    target = ctrl / gear - model.qpos0[model.jnt_qposadr[joint_id]]
    convert = per_degree if angular else float
    drive.CreateStiffnessAttr(convert(gear**2 * kp))
    drive.CreateDampingAttr(convert(gear**2 * kv))
    drive.CreateTargetPositionAttr(float(np.degrees(target) if angular else target))


def _effort_limit(model: mujoco.MjModel, actuator: int, kind: str) -> float:
    """The largest joint torque (force) the actuator gives: its force range, and for a motor also its
    control range, times |gear|."""
    limit = np.inf
    if model.actuator_forcelimited[actuator]:
        limit = np.abs(model.actuator_forcerange[actuator]).max()
    if kind == "motor" and model.actuator_ctrllimited[actuator]:
        limit = min(limit, np.abs(model.actuator_ctrlrange[actuator]).max() * model.actuator_gainprm[actuator, 0])
    return float(limit * abs(model.actuator_gear[actuator, 0]))
