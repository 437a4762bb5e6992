"""DriveAPI drives as MuJoCo actuators (named after their joint, or as the exporter's joshua:actuator* say). USD
angular drives are per degree; everything here is converted to SI."""

from __future__ import annotations

import math

import mujoco
from pxr import Usd, UsdPhysics

from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.stage import StageFrame, positive, read


def add_drive(
    spec: mujoco.MjSpec, prim: Usd.Prim, joint: mujoco.MjsJoint, frame: StageFrame, report: ImportReport
) -> float | None:
    """Add the actuator of the joint's drive (position with stiffness, velocity with damping only, motor with
    neither) and return its target (the ctrl that holds it), or None when the joint has no drive. The
    exporter's joshua:actuator* attributes, where present, restore the MuJoCo actuator's name, gear and
    ctrlrange (the drive holds joint torques: gains / gear^2, force limit / gear, ctrl = gear x target)."""
    angular = joint.type == mujoco.mjtJoint.mjJNT_HINGE
    instance = "angular" if angular else "linear" if joint.type == mujoco.mjtJoint.mjJNT_SLIDE else "none"
    schemas = prim.GetAppliedSchemas()
    for api in [api for api in schemas if api.startswith("PhysicsDriveAPI:") and api != f"PhysicsDriveAPI:{instance}"]:
        report.warn(prim.GetPath(), f"{api} does not drive a {joint.type.name} joint: ignored")
    if not prim.HasAPI(UsdPhysics.DriveAPI, instance):
        return None
    position_unit, force_unit = frame.joint_units(angular)
    gear = _gear(prim, report)
    attribute = f"drive:{instance}:physics:"
    stiffness, damping = (
        positive(prim, attribute + key, read(prim, attribute + key, report), report)
        * force_unit
        / position_unit
        / gear**2
        for key in ("stiffness", "damping")
    )
    if read(prim, attribute + "type", report) == "acceleration":
        report.warn(prim.GetPath(), "an acceleration drive's gains are used as force gains (not scaled by inertia)")
    name = read(prim, "joshua:actuator", report) or joint.name
    actuator = spec.add_actuator(name=name, target=joint.name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    actuator.gear[0] = gear
    max_force = read(prim, attribute + "maxForce", report, allow_inf=True)
    if max_force is not None and math.isfinite(max_force):
        actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        limit = max_force * force_unit / abs(gear)
        actuator.forcerange = [-limit, limit]
    target_position = read(prim, attribute + "targetPosition", report) * position_unit * gear
    target_velocity = read(prim, attribute + "targetVelocity", report) * position_unit * gear
    if stiffness > 0:
        limited = joint.limited == mujoco.mjtLimited.mjLIMITED_TRUE
        actuator.set_to_position(kp=stiffness, kv=damping, inheritrange=limited)
        if target_velocity:
            report.warn(prim.GetPath(), "targetVelocity of a drive with stiffness is not supported: ignored")
        target = target_position
    elif damping > 0:
        actuator.set_to_velocity(kv=damping)
        target = target_velocity
    else:
        actuator.set_to_motor()
        if max_force is not None and math.isfinite(max_force):
            actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
            actuator.ctrlrange = actuator.forcerange
        target = 0.0
    ctrl_range = read(prim, "joshua:actuator:ctrlRange", report)
    if ctrl_range is not None:
        actuator.inheritrange = 0.0
        actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        actuator.ctrlrange = [float(value) for value in ctrl_range]
    return target


def _gear(prim: Usd.Prim, report: ImportReport) -> float:
    """joshua:actuator:gear (1 when absent); zero is a ModelError."""
    gear = read(prim, "joshua:actuator:gear", report)
    if gear == 0:
        raise report.error(prim.GetPath(), "joshua:actuator:gear", "must not be zero")
    return 1.0 if gear is None else float(gear)
