"""DriveAPI drives as MuJoCo actuators (named after their joint, or as the exporter's joshua:actuator* say) and
PhysX joint attributes MuJoCo has an equivalent of. USD angular drives are per degree; everything here is
converted to SI."""

from __future__ import annotations

import math

import mujoco
from pxr import Usd, UsdPhysics

from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.stage import StageFrame, positive, read, read_physx
from joshua_usd.physx_schema import JOINT_AXES, attribute_name

# Above this (deg/s or units/s) PhysX's max joint velocity is Isaac's "unlimited" default: not warned about.
UNLIMITED_VELOCITY = 1e6
# PhysxJointAPI: gone from the PhysX schemas (physx-usd-schemas 25.11; ovphysx 0.7 ignores it), still in Isaac assets
# written before: its attributes are read by name, per joint, where the joint's PhysxJointAxisAPI has no value.
LEGACY_JOINT_NAMESPACE = "physxJoint"
FRICTION_ATTRIBUTES = (f"{LEGACY_JOINT_NAMESPACE}:jointFriction", "physics:jointFriction")
# The PhysxJointAxisAPI instances read per joint type: PhysX's, and "angular" on ball joints too (exports before
# the PhysX schemas wrote it there).
AXIS_INSTANCES = {**JOINT_AXES, mujoco.mjtJoint.mjJNT_BALL: ("angular", *JOINT_AXES[mujoco.mjtJoint.mjJNT_BALL])}


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
    position_unit, force_unit = _units(angular, frame)
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


def joint_properties(prim: Usd.Prim, joint: mujoco.MjsJoint, frame: StageFrame, report: ImportReport) -> None:
    """PhysX joint attributes, per axis (PhysxJointAxisAPI) before per joint (PhysxJointAPI): armature, viscous
    friction (MuJoCo's damping), friction effort (frictionloss) and max velocity (warned)."""
    angular = joint.type != mujoco.mjtJoint.mjJNT_SLIDE
    instances = AXIS_INSTANCES[joint.type]
    position_unit, force_unit = _units(angular, frame)
    armature = _joint_value(prim, instances, "armature", report)
    if armature:  # an inertia (kg unit^2) for angular joints, a mass for linear ones
        inertia_unit = frame.kilograms_per_unit * (frame.meters_per_unit**2 if angular else 1.0)
        joint.armature = positive(prim, armature[0], armature[1], report) * inertia_unit
    viscous = _joint_value(prim, instances, "viscousFrictionCoefficient", report, joint_level=False)
    if viscous:  # per degree on angular axes, like drive damping
        joint.damping[0] = positive(prim, viscous[0], viscous[1], report) * force_unit / position_unit
    friction = _friction_effort(prim, instances, report)
    if friction:
        joint.frictionloss = positive(prim, friction[0], friction[1], report) * force_unit
    velocity = _joint_value(prim, instances, "maxJointVelocity", report, allow_inf=True)
    if velocity and velocity[1] < UNLIMITED_VELOCITY:
        report.warn(prim.GetPath(), f"{velocity[0]} {velocity[1]:.6g} is not enforced by MuJoCo")


def _joint_value(
    prim: Usd.Prim,
    instances: tuple[str, ...],
    key: str,
    report: ImportReport,
    *,
    joint_level: bool = True,
    allow_inf: bool = False,
) -> tuple[str, float] | None:
    """(attribute, value) of PhysxJointAxisAPI's <key> for the joint's axis instances (the largest where a ball
    joint's differ: MuJoCo has one value per joint, warned), else of physxJoint:<key>; None if unauthored."""
    found = {
        attribute_name("PhysxJointAxisAPI", key, instance): value
        for instance in instances
        if (value := read_physx(prim, "PhysxJointAxisAPI", key, report, instance=instance, allow_inf=allow_inf))
        is not None
    }
    if len(set(found.values())) > 1:
        report.warn(prim.GetPath(), f"{key} differs between axes: MuJoCo uses the largest on every axis")
    if found:
        name = max(found, key=found.__getitem__)
        return name, float(found[name])
    name = f"{LEGACY_JOINT_NAMESPACE}:{key}"
    value = read(prim, name, report, allow_inf=allow_inf) if joint_level else None
    return None if value is None else (name, float(value))


def _friction_effort(prim: Usd.Prim, instances: tuple[str, ...], report: ImportReport) -> tuple[str, float] | None:
    """The joint's Coulomb friction torque (force): dynamicFrictionEffort, else staticFrictionEffort (warned where
    both differ), else PhysX's joint friction coefficient taken as one (warned)."""
    dynamic = _joint_value(prim, instances, "dynamicFrictionEffort", report, joint_level=False)
    static = _joint_value(prim, instances, "staticFrictionEffort", report, joint_level=False)
    if dynamic and static and abs(dynamic[1] - static[1]) > 1e-9:
        report.warn(
            prim.GetPath(),
            f"staticFrictionEffort {static[1]:.6g} differs from dynamicFrictionEffort "
            f"{dynamic[1]:.6g}: MuJoCo's frictionloss is the dynamic one",
        )
    if dynamic or static:
        return dynamic or static
    for name in FRICTION_ATTRIBUTES:
        friction = read(prim, name, report)
        if friction:
            report.warn(prim.GetPath(), f"{name} (a PhysX coefficient) is used as MuJoCo's frictionloss in SI units")
            return name, float(friction)
    return None
