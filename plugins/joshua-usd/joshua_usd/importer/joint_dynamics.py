"""A joint's dynamics (armature, damping, friction, springs, limit softness, reference) from the three schema
families that carry them. For each quantity the first authored of Newton's NewtonJointAPI (`newton:*`, what
mujoco-usd-converter writes), MuJoCo's MjcJointAPI (`mjc:*`) and PhysX's PhysxJointAxisAPI / PhysxJointAPI is used:
Newton's and MuJoCo's describe MuJoCo's own joint model, PhysX's are tuned for PhysX's solver. A name further down
that order is then not read at all, so `joshua usd inspect` lists it among the attributes the import did not use.

Units: Newton's are the stage's (angles in degrees, so angular damping is per degree); MuJoCo's are MuJoCo's, SI
as authored, with `mjc:ref` and `mjc:springref` of hinges in the unit `mjc:compiler:angle` names (degrees unless
it says "radian"); PhysX's are the stage's, per degree."""

from __future__ import annotations

import mujoco
from pxr import Usd

from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.stage import (
    StageFrame,
    positive,
    read,
    read_array,
    read_authored,
    read_number,
    read_physx,
)
from joshua_usd.physx_schema import JOINT_AXES, attribute_name

# Above this (deg/s or units/s) a joint velocity limit is Isaac's "unlimited" default: not warned about.
UNLIMITED_VELOCITY = 1e6
# PhysxJointAPI: gone from the PhysX schemas (physx-usd-schemas 25.11; ovphysx 0.7 ignores it), still in Isaac assets
# written before: its attributes are read by name, per joint, where the joint's PhysxJointAxisAPI has no value.
LEGACY_JOINT_NAMESPACE = "physxJoint"
FRICTION_ATTRIBUTES = (f"{LEGACY_JOINT_NAMESPACE}:jointFriction", "physics:jointFriction")
# The PhysxJointAxisAPI instances read per joint type: PhysX's, and "angular" on ball joints too (exports before
# the PhysX schemas wrote it there).
AXIS_INSTANCES = {**JOINT_AXES, mujoco.mjtJoint.mjJNT_BALL: ("angular", *JOINT_AXES[mujoco.mjtJoint.mjJNT_BALL])}
LIMITED = {
    "false": mujoco.mjtLimited.mjLIMITED_FALSE,
    "true": mujoco.mjtLimited.mjLIMITED_TRUE,
    "auto": mujoco.mjtLimited.mjLIMITED_AUTO,
}
# MjcJointAPI arrays copied as authored: (attribute, MjsJoint field, size).
MJC_ARRAYS = (
    ("mjc:solreflimit", "solref_limit", mujoco.mjNREF),
    ("mjc:solimplimit", "solimp_limit", mujoco.mjNIMP),
    ("mjc:solreffriction", "solref_friction", mujoco.mjNREF),
    ("mjc:solimpfriction", "solimp_friction", mujoco.mjNIMP),
    ("mjc:springdamper", "springdamper", 2),
)

Found = tuple[str, float]  # (attribute, value in SI)


def joint_properties(
    prim: Usd.Prim, joint: mujoco.MjsJoint, frame: StageFrame, angle: float, report: ImportReport
) -> None:
    """Set `joint`'s armature, damping, frictionloss, spring, limit and friction softness, actuator force range and
    reference from the joint prim; `angle` is radians per unit of MuJoCo's angles (`mjc:compiler:angle`)."""
    angular = joint.type != mujoco.mjtJoint.mjJNT_SLIDE
    position_unit, force_unit = frame.joint_units(angular)
    inertia_unit = frame.kilograms_per_unit * (frame.meters_per_unit**2 if angular else 1.0)
    instances = AXIS_INSTANCES[joint.type]
    armature = _newton_or_mjc(prim, (("newton:armature", inertia_unit), ("mjc:armature", 1.0)), report)
    armature = armature or _physx_value(prim, instances, "armature", report, scale=inertia_unit)
    if armature:
        joint.armature = armature[1]
    damping = _newton_or_mjc(prim, (("newton:damping", force_unit / position_unit), ("mjc:damping", 1.0)), report)
    damping = damping or _physx_value(
        prim, instances, "viscousFrictionCoefficient", report, joint_level=False, scale=force_unit / position_unit
    )
    if damping:
        joint.damping[0] = damping[1]
    friction = _newton_or_mjc(prim, (("newton:friction", force_unit), ("mjc:frictionloss", 1.0)), report)
    friction = friction or _friction_effort(prim, instances, force_unit, report)
    if friction:
        joint.frictionloss = friction[1]
    _velocity_limit(prim, instances, report)
    _mjc_joint(prim, joint, angle if angular else 1.0, report)


def _newton_or_mjc(prim: Usd.Prim, names: tuple[tuple[str, float], ...], report: ImportReport) -> Found | None:
    """(attribute, value x scale) of the first authored of `names` ((attribute, SI per unit) pairs); negative is a
    ModelError."""
    for name, scale in names:
        value = read_number(prim, name, report, authored=True)
        if value is not None:
            return name, positive(prim, name, value, report) * scale
    return None


def _physx_value(
    prim: Usd.Prim,
    instances: tuple[str, ...],
    key: str,
    report: ImportReport,
    *,
    scale: float = 1.0,
    joint_level: bool = True,
    allow_inf: bool = False,
) -> Found | None:
    """(attribute, value x scale) of PhysxJointAxisAPI's <key> for the joint's axis instances (the largest where a
    ball joint's differ: MuJoCo has one value per joint, warned), else of physxJoint:<key>; None if unauthored.
    Negative is a ModelError."""
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
        return name, positive(prim, name, float(found[name]), report) * scale
    name = f"{LEGACY_JOINT_NAMESPACE}:{key}"
    value = read(prim, name, report, allow_inf=allow_inf) if joint_level else None
    return None if value is None else (name, positive(prim, name, float(value), report) * scale)


def _friction_effort(prim: Usd.Prim, instances: tuple[str, ...], unit: float, report: ImportReport) -> Found | None:
    """PhysX's Coulomb friction torque (force), x `unit`: dynamicFrictionEffort, else staticFrictionEffort (warned
    where both differ), else PhysX's joint friction coefficient taken as one (warned)."""
    dynamic = _physx_value(prim, instances, "dynamicFrictionEffort", report, joint_level=False, scale=unit)
    static = _physx_value(prim, instances, "staticFrictionEffort", report, joint_level=False, scale=unit)
    if dynamic and static and abs(dynamic[1] - static[1]) > 1e-9 * unit:
        report.warn(
            prim.GetPath(),
            f"staticFrictionEffort {static[1] / unit:.6g} differs from dynamicFrictionEffort "
            f"{dynamic[1] / unit:.6g}: MuJoCo's frictionloss is the dynamic one",
        )
        report.ignore(prim.GetPath(), static[0])
    if dynamic or static:
        return dynamic or static
    for name in FRICTION_ATTRIBUTES:
        friction = read(prim, name, report)
        if friction:
            report.warn(prim.GetPath(), f"{name} (a PhysX coefficient) is used as MuJoCo's frictionloss in SI units")
            return name, positive(prim, name, float(friction), report)
    return None


def _velocity_limit(prim: Usd.Prim, instances: tuple[str, ...], report: ImportReport) -> None:
    """Warn about a finite joint velocity limit (newton:velocityLimit, else PhysX's maxJointVelocity, deg/s or
    units/s): MuJoCo has none, so it is not used; an unlimited one is what MuJoCo does."""
    limit = read_number(prim, "newton:velocityLimit", report, authored=True, allow_inf=True)
    found = ("newton:velocityLimit", limit) if limit is not None else None
    found = found or _physx_value(prim, instances, "maxJointVelocity", report, allow_inf=True)
    if found and found[1] < UNLIMITED_VELOCITY:
        report.warn(prim.GetPath(), f"{found[0]} {found[1]:.6g} is not enforced by MuJoCo")
        report.ignore(prim.GetPath(), found[0])


def _mjc_joint(prim: Usd.Prim, joint: mujoco.MjsJoint, angle: float, report: ImportReport) -> None:
    """MjcJointAPI's MuJoCo-only joint settings, where authored: the spring (stiffness N m/rad or N/m, springref,
    springdamper), the reference added to the joint value at the authored pose (MuJoCo's qpos there, in which the
    converter writes the limits), softness of limits and friction (solref, solimp, margin), actuator force limits,
    gravity compensation and group. `angle` converts hinge references to radians."""
    scalar = joint.type in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)
    if scalar and (ref := read_number(prim, "mjc:ref", report, authored=True)) is not None:
        joint.ref += ref * angle
    if scalar and (springref := read_number(prim, "mjc:springref", report, authored=True)) is not None:
        joint.springref = springref * angle
    if (stiffness := read_number(prim, "mjc:stiffness", report, authored=True)) is not None:
        joint.stiffness[0] = positive(prim, "mjc:stiffness", stiffness, report)
    for attribute, field, size in MJC_ARRAYS:
        if (values := read_array(prim, attribute, size, report)) is not None:
            setattr(joint, field, values)
    if (margin := read_number(prim, "mjc:margin", report, authored=True)) is not None:
        joint.margin = margin
    token = read_authored(prim, "mjc:actuatorfrclimited", report)
    if token is not None:
        if str(token) not in LIMITED:
            raise report.error(prim.GetPath(), "mjc:actuatorfrclimited", f"must be false, true or auto, got {token}")
        joint.actfrclimited = LIMITED[str(token)]
    low, high = (read_number(prim, f"mjc:actuatorfrcrange:{end}", report, authored=True) for end in ("min", "max"))
    if low is not None or high is not None:
        joint.actfrcrange = [low or 0.0, high or 0.0]
    if (gravcomp := read_number(prim, "mjc:actuatorgravcomp", report, authored=True)) is not None:
        joint.actgravcomp = bool(gravcomp)
    if (group := read_number(prim, "mjc:group", report, authored=True, integer=True)) is not None:
        joint.group = int(group)
