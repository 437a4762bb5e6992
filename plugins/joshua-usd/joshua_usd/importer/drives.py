"""DriveAPI drives as MuJoCo actuators (named after their joint) and PhysX joint attributes MuJoCo has an
equivalent of. USD angular drives are per degree; everything here is converted to SI."""

from __future__ import annotations

import math

import mujoco
from pxr import Usd, UsdPhysics

from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.stage import StageFrame, positive, read

# Above this (deg/s or units/s) PhysX's max joint velocity is Isaac's "unlimited" default: not warned about.
UNLIMITED_VELOCITY = 1e6
FRICTION_ATTRIBUTES = ("physxJoint:jointFriction", "physics:jointFriction")


def _units(angular: bool, frame: StageFrame) -> tuple[float, float]:
    """(SI per stage unit of position, SI per stage unit of force/torque) for an angular or linear joint."""
    kilograms, meters = frame.kilograms_per_unit, frame.meters_per_unit
    if angular:
        return math.pi / 180, kilograms * meters**2
    return meters, kilograms * meters


def add_drive(
    spec: mujoco.MjSpec, prim: Usd.Prim, joint: mujoco.MjsJoint, frame: StageFrame, report: ImportReport
) -> float | None:
    """Add the actuator of the joint's drive (position with stiffness, velocity with damping only, motor with
    neither) and return its target (the ctrl that holds it), or None when the joint has no drive."""
    angular = joint.type == mujoco.mjtJoint.mjJNT_HINGE
    instance = "angular" if angular else "linear" if joint.type == mujoco.mjtJoint.mjJNT_SLIDE else "none"
    schemas = prim.GetAppliedSchemas()
    for api in [api for api in schemas if api.startswith("PhysicsDriveAPI:") and api != f"PhysicsDriveAPI:{instance}"]:
        report.warn(prim.GetPath(), f"{api} does not drive a {joint.type.name} joint: ignored")
    if not prim.HasAPI(UsdPhysics.DriveAPI, instance):
        return None
    position_unit, force_unit = _units(angular, frame)
    attribute = f"drive:{instance}:physics:"
    stiffness, damping = (
        positive(prim, attribute + key, read(prim, attribute + key, report), report) * force_unit / position_unit
        for key in ("stiffness", "damping")
    )
    if read(prim, attribute + "type", report) == "acceleration":
        report.warn(prim.GetPath(), "an acceleration drive's gains are used as force gains (not scaled by inertia)")
    actuator = spec.add_actuator(name=joint.name, target=joint.name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    max_force = read(prim, attribute + "maxForce", report, allow_inf=True)
    if max_force is not None and math.isfinite(max_force):
        actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        actuator.forcerange = [-max_force * force_unit, max_force * force_unit]
    target_position = read(prim, attribute + "targetPosition", report) * position_unit
    target_velocity = read(prim, attribute + "targetVelocity", report) * position_unit
    if stiffness > 0:
        limited = joint.limited == mujoco.mjtLimited.mjLIMITED_TRUE
        actuator.set_to_position(kp=stiffness, kv=damping, inheritrange=limited)
        if target_velocity:
            report.warn(prim.GetPath(), "targetVelocity of a drive with stiffness is not supported: ignored")
        return target_position
    if damping > 0:
        actuator.set_to_velocity(kv=damping)
        return target_velocity
    actuator.set_to_motor()
    if max_force is not None and math.isfinite(max_force):
        actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        actuator.ctrlrange = actuator.forcerange
    return 0.0


def joint_properties(prim: Usd.Prim, joint: mujoco.MjsJoint, frame: StageFrame, report: ImportReport) -> None:
    """PhysX joint attributes: armature, joint friction (as MuJoCo's frictionloss), max velocity (warned)."""
    angular = joint.type != mujoco.mjtJoint.mjJNT_SLIDE
    _, force_unit = _units(angular, frame)
    armature = read(prim, "physxJoint:armature", report)
    if armature:  # an inertia (kg unit^2) for angular joints, a mass for linear ones
        inertia_unit = frame.kilograms_per_unit * (frame.meters_per_unit**2 if angular else 1.0)
        joint.armature = positive(prim, "physxJoint:armature", armature, report) * inertia_unit
    for name in FRICTION_ATTRIBUTES:
        friction = read(prim, name, report)
        if friction:
            joint.frictionloss = positive(prim, name, friction, report) * force_unit
            report.warn(prim.GetPath(), f"{name} (a PhysX coefficient) is used as MuJoCo's frictionloss in SI units")
            break
    velocity = read(prim, "physxJoint:maxJointVelocity", report, allow_inf=True)
    if velocity is not None and velocity < UNLIMITED_VELOCITY:
        report.warn(prim.GetPath(), f"physxJoint:maxJointVelocity {velocity:.6g} is not enforced by MuJoCo")
