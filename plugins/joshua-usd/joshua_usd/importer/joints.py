"""Joints: where each body sits in its parent (from the joint frames localPos/localRot of body0 and body1,
checked against the stage's world transforms) and the MuJoCo joint with its axis, limits and reference."""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from pxr import Usd

from joshua_usd.importer.pose import IDENTITY, Pose, Vec, axis_angle, quat_angle, rotate
from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.stage import StageFrame, read, read_quat
from joshua_usd.importer.topology import Link

AXES = {"X": np.array([1.0, 0, 0]), "Y": np.array([0, 1.0, 0]), "Z": np.array([0, 0, 1.0])}
# Frames of body0 and body1 that disagree by more than this (beyond the joint's own motion) are warned about.
POSITION_TOLERANCE = 1e-4  # metres
ANGLE_TOLERANCE = math.radians(0.05)


@dataclass(frozen=True)
class Placement:
    """A link's pose in its parent body, its joint frame in its own body, the joint axis (in that joint frame,
    negated for a reversed joint) and the joint value at the authored pose (MuJoCo's `ref`)."""

    in_parent: Pose
    child_frame: Pose
    axis: Vec
    value: float


def place(link: Link, frame: StageFrame, report: ImportReport) -> Placement:
    """Where `link` sits in its parent: a jointless root at its stage pose, a jointed link through the joint
    frames at the joint value its stage pose implies; frames that disagree otherwise are warned about."""
    if link.joint is None:
        return Placement(frame.world_pose(link.prim)[0], IDENTITY, AXES["Z"], 0.0)
    joint = link.joint
    ends = ((joint.body0, joint.frame0, "0"), (joint.body1, joint.frame1, "1"))
    parent_end, child_end = ends[::-1] if link.reversed else ends
    parent_pose, parent_frame = _joint_frame(joint.prim, *parent_end, frame, report)
    child_pose, child_frame = _joint_frame(joint.prim, *child_end, frame, report)
    axis = AXES.get(str(read(joint.prim, "physics:axis", report) or "X"), AXES["X"]) * (-1 if link.reversed else 1)
    relative = (parent_pose * parent_frame).inverse() * (child_pose * child_frame)
    motion, value = _joint_motion(joint.kind, axis, relative)
    residual = motion.inverse() * relative
    offset, angle = float(np.linalg.norm(residual.pos)), quat_angle(residual.quat)
    if offset > POSITION_TOLERANCE or angle > ANGLE_TOLERANCE:
        report.warn(
            joint.prim.GetPath(),
            f"the joint frames of body0 and body1 disagree by {offset:.4g} m and {math.degrees(angle):.3g} deg "
            "beyond the joint's motion: the child body is placed by the joint frames",
        )
    in_parent = parent_frame * motion * child_frame.inverse()
    if parent_end[0] is None:  # MuJoCo's world frame is not the stage's: it is metres and Z up
        in_parent = parent_pose * in_parent
    return Placement(in_parent, child_frame, axis, value)


def _joint_frame(
    prim: Usd.Prim,
    body: Usd.Prim | None,
    target: Usd.Prim | None,
    index: str,
    frame: StageFrame,
    report: ImportReport,
) -> tuple[Pose, Pose]:
    """The stage pose of body`index` in the world and the joint frame in that body (localPos scaled to metres).
    localPos/localRot are given in the frame of the rel's `target`, which may be a prim inside the body or, for
    the world, a prim that is no body: they are then carried through the target's pose into the body's frame."""
    body_pose, scale = frame.world_pose(body)
    position = read(prim, f"physics:localPos{index}", report)
    rotation = read_quat(prim, f"physics:localRot{index}", report)
    position = np.asarray(position if position is not None else (0, 0, 0), dtype=np.float64)
    rotation = rotation if rotation is not None else IDENTITY.quat
    if (target.GetPath() if target else None) == (body.GetPath() if body else None):
        return body_pose, Pose(scale * position, rotation)
    target_pose, target_scale = frame.world_pose(target)
    return body_pose, body_pose.inverse() * target_pose * Pose(target_scale * position, rotation)


def _joint_motion(kind: str, axis: Vec, relative: Pose) -> tuple[Pose, float]:
    """The part of `relative` (child joint frame in the parent's) the joint allows, and the joint value."""
    if kind == "revolute":
        angle = 2 * math.atan2(float(np.dot(relative.quat[1:], axis)), float(relative.quat[0]))
        angle = math.remainder(angle, 2 * math.pi)
        return Pose(np.zeros(3), axis_angle(axis, angle)), angle
    if kind == "prismatic":
        distance = float(np.dot(relative.pos, axis))
        return Pose(distance * axis, IDENTITY.quat), distance
    if kind == "spherical":
        return Pose(np.zeros(3), relative.quat), 0.0
    return IDENTITY, 0.0


def add_joint(
    body: mujoco.MjsBody, link: Link, placement: Placement, name: str, frame: StageFrame, report: ImportReport
) -> mujoco.MjsJoint | None:
    """The MuJoCo joint of a revolute, prismatic or spherical link (None for a fixed one: welded)."""
    assert link.joint is not None
    kind, prim = link.joint.kind, link.joint.prim
    if kind == "fixed":
        return None
    joint = body.add_joint(name=name, pos=placement.child_frame.pos)
    if kind == "spherical":
        joint.type = mujoco.mjtJoint.mjJNT_BALL
        _cone_limit(joint, prim, report)
        return joint
    joint.axis = rotate(placement.child_frame.quat, placement.axis)
    joint.ref = placement.value
    angular = kind == "revolute"
    joint.type = mujoco.mjtJoint.mjJNT_HINGE if angular else mujoco.mjtJoint.mjJNT_SLIDE
    unit = math.pi / 180 if angular else frame.meters_per_unit
    lower, upper = (read(prim, f"physics:{end}Limit", report, allow_inf=True) for end in ("lower", "upper"))
    if lower is not None and upper is not None and math.isfinite(lower) and math.isfinite(upper):
        if lower > upper:
            raise report.error(prim.GetPath(), "physics:lowerLimit", f"{lower} is above upperLimit {upper}")
        joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        joint.range = [lower * unit, upper * unit]
    elif lower is not None and upper is not None and (math.isfinite(lower) or math.isfinite(upper)):
        report.warn(prim.GetPath(), "a one-sided limit is not supported by MuJoCo: the joint is unlimited")
    return joint


def _cone_limit(joint: mujoco.MjsJoint, prim: Usd.Prim, report: ImportReport) -> None:
    """A spherical joint's swing cone (degrees) as MuJoCo's limit on the total rotation angle, warned about."""
    cones = [read(prim, f"physics:coneAngle{index}Limit", report, allow_inf=True) for index in ("0", "1")]
    finite = [angle for angle in cones if angle is not None and math.isfinite(angle) and angle >= 0]
    if not finite:
        return
    limit = max(finite)
    joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
    joint.range = [0.0, math.radians(limit)]
    shown = "/".join("none" if angle is None else f"{angle:.6g}" for angle in cones)
    report.warn(
        prim.GetPath(),
        f"cone limits {shown} deg are approximated by MuJoCo's ball limit of {limit:.6g} deg on the "
        "total rotation angle (twist included)",
    )
