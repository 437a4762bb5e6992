"""MuJoCo's own USD physics schema (mjcPhysics) actuators: `MjcActuator` prims, as `mujoco-usd-converter` writes
them, and prims with `MjcActuatorAPI` applied (the prim is the transmission target), read into MuJoCo actuators.

Their attributes are MjsActuator's fields under other names: the compiler converts none of them by its angle
setting (`mjc:compiler:angle` matters for joint ranges only), so they are used as authored, in MuJoCo's units."""

from __future__ import annotations

import reprlib
from collections.abc import Iterator, Mapping
from typing import Any

import mujoco
import numpy as np
from pxr import Sdf, Usd

from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.stage import StageFrame, applied, prims, read, read_number

ACTUATOR_TYPE = "MjcActuator"
ACTUATOR_API = "MjcActuatorAPI"
LIMITED = {
    "false": mujoco.mjtLimited.mjLIMITED_FALSE,
    "true": mujoco.mjtLimited.mjLIMITED_TRUE,
    "auto": mujoco.mjtLimited.mjLIMITED_AUTO,
}
# The built-in kinds; "user" needs callbacks a USD file cannot supply.
DYN_TYPES = {
    "none": mujoco.mjtDyn.mjDYN_NONE,
    "integrator": mujoco.mjtDyn.mjDYN_INTEGRATOR,
    "filter": mujoco.mjtDyn.mjDYN_FILTER,
    "filterexact": mujoco.mjtDyn.mjDYN_FILTEREXACT,
    "muscle": mujoco.mjtDyn.mjDYN_MUSCLE,
}
GAIN_TYPES = {
    "fixed": mujoco.mjtGain.mjGAIN_FIXED,
    "affine": mujoco.mjtGain.mjGAIN_AFFINE,
    "muscle": mujoco.mjtGain.mjGAIN_MUSCLE,
}
BIAS_TYPES = {
    "none": mujoco.mjtBias.mjBIAS_NONE,
    "affine": mujoco.mjtBias.mjBIAS_AFFINE,
    "muscle": mujoco.mjtBias.mjBIAS_MUSCLE,
}
# (attribute, MjsActuator field, parameter count) of the parameter arrays (mjNDYN = mjNGAIN = mjNBIAS = 10).
ARRAYS = (("mjc:dynPrm", "dynprm", 10), ("mjc:gainPrm", "gainprm", 10), ("mjc:biasPrm", "biasprm", 10))
RANGES = (
    ("ctrl", "ctrllimited", "ctrlrange"),
    ("force", "forcelimited", "forcerange"),
    ("act", "actlimited", "actrange"),
)
UNSUPPORTED_RELATIONSHIPS = ("mjc:refSite", "mjc:sliderSite")


def mjc_actuators(stage: Usd.Stage) -> Iterator[Usd.Prim]:
    """The stage's MjcActuator prims and prims with MjcActuatorAPI, in stage order."""
    for prim in prims(stage):
        if prim.GetTypeName() == ACTUATOR_TYPE or applied(prim, ACTUATOR_API):
            yield prim


def add_mjc_actuators(
    spec: mujoco.MjSpec,
    found: list[Usd.Prim],
    names: Mapping[Sdf.Path, str],
    joints: Mapping[Sdf.Path, mujoco.MjsJoint],
    bodies: Mapping[Sdf.Path, mujoco.MjsBody],
    frame: StageFrame,
    report: ImportReport,
) -> int:
    """Add an actuator, named `names[path]`, for each mjcPhysics actuator prim in `found` whose target became a
    MuJoCo joint or body; the others (site, slider-crank and user-defined kinds) are warned about and left out.
    Returns how many were added."""
    if found and (frame.meters_per_unit != 1.0 or frame.kilograms_per_unit != 1.0):
        report.warn("/", "mjc:* actuator values are used as authored (MuJoCo's SI units), not scaled by the stage's")
    added = 0
    for prim in found:
        actuator = _new_actuator(spec, prim, names[prim.GetPath()], joints, bodies, report)
        if actuator is not None:
            _set_parameters(prim, actuator, report)
            added += 1
    return added


def _new_actuator(
    spec: mujoco.MjSpec,
    prim: Usd.Prim,
    name: str,
    joints: Mapping[Sdf.Path, mujoco.MjsJoint],
    bodies: Mapping[Sdf.Path, mujoco.MjsBody],
    report: ImportReport,
) -> mujoco.MjsActuator | None:
    """The actuator on the prim's transmission target (its mjc:target, or the prim itself for MjcActuatorAPI),
    or None (warned) where the kind is not supported."""
    path = prim.GetPath()
    unsupported = [name for name in UNSUPPORTED_RELATIONSHIPS if prim.GetRelationship(name).GetTargets()]
    kinds = {
        attribute: str(value)
        for attribute, table in (("mjc:dynType", DYN_TYPES), ("mjc:gainType", GAIN_TYPES), ("mjc:biasType", BIAS_TYPES))
        if (value := read(prim, attribute, report)) is not None and str(value) not in table
    }
    unsupported += [f"{attribute} {value}" for attribute, value in kinds.items()]
    if unsupported:
        report.warn(path, f"MjcActuator with {', '.join(unsupported)} is not supported: not imported")
        return None
    if prim.GetTypeName() == ACTUATOR_TYPE:
        targets = prim.GetRelationship("mjc:target").GetTargets()
        if len(targets) != 1:
            report.warn(path, f"MjcActuator with {len(targets)} mjc:target(s) (needs one): not imported")
            return None
        target = targets[0]
    else:
        target = path
    if target in joints:
        in_parent = bool(read_number(prim, "mjc:jointInParent", report))
        transmission = mujoco.mjtTrn.mjTRN_JOINTINPARENT if in_parent else mujoco.mjtTrn.mjTRN_JOINT
        return spec.add_actuator(name=name, target=joints[target].name, trntype=transmission)
    if target in bodies:
        return spec.add_actuator(name=name, target=bodies[target].name, trntype=mujoco.mjtTrn.mjTRN_BODY)
    report.warn(path, f"MjcActuator target <{target}> is not an imported joint or rigid body: not imported")
    return None


def _set_parameters(prim: Usd.Prim, actuator: mujoco.MjsActuator, report: ImportReport) -> None:
    """Copy the authored mjc:* values onto the actuator (MuJoCo's defaults where unauthored, as the schema's)."""
    for attribute, table, field in (
        ("mjc:dynType", DYN_TYPES, "dyntype"),
        ("mjc:gainType", GAIN_TYPES, "gaintype"),
        ("mjc:biasType", BIAS_TYPES, "biastype"),
    ):
        if (value := read(prim, attribute, report)) is not None:
            setattr(actuator, field, table[str(value)])
    for attribute, field, size in ARRAYS:
        if (values := _array(prim, attribute, size, report)) is not None:
            setattr(actuator, field, values)
    if (gear := _array(prim, "mjc:gear", 6, report)) is not None:
        actuator.gear = gear
    for kind, limited, bounds in RANGES:
        token = read(prim, f"mjc:{kind}Limited", report)
        if token is not None:
            if str(token) not in LIMITED:
                raise report.error(prim.GetPath(), f"mjc:{kind}Limited", f"must be false, true or auto, got {token}")
            setattr(actuator, limited, LIMITED[str(token)])
        low, high = (read_number(prim, f"mjc:{kind}Range:{end}", report) for end in ("min", "max"))
        if low is not None or high is not None:
            setattr(actuator, bounds, [low or 0.0, high or 0.0])
    low, high = (read_number(prim, f"mjc:lengthRange:{end}", report) for end in ("min", "max"))
    if low is not None or high is not None:
        actuator.lengthrange = [low or 0.0, high or 0.0]
    for attribute, field, integer in (
        ("mjc:group", "group", True),
        ("mjc:actDim", "actdim", True),
        ("mjc:actEarly", "actearly", True),
        ("mjc:inheritRange", "inheritrange", False),
    ):
        if (value := read_number(prim, attribute, report, integer=integer)) is not None:
            setattr(actuator, field, value)


def _array(prim: Usd.Prim, attribute: str, size: int, report: ImportReport) -> np.ndarray | None:
    """The authored array padded with zeros to `size`; longer arrays, and values that are not an array of numbers,
    are a ModelError (MuJoCo holds `size` numbers)."""
    value: Any = read(prim, attribute, report)
    if value is None:
        return None
    try:
        values = None if isinstance(value, str) else np.asarray(list(value), dtype=np.float64)
    except (TypeError, ValueError):  # a number, or an array of strings
        values = None
    if values is None or values.ndim != 1:
        raise report.error(prim.GetPath(), attribute, f"must be an array of numbers, got {reprlib.repr(value)}")
    if values.size > size:
        raise report.error(prim.GetPath(), attribute, f"has {values.size} values, MuJoCo holds {size}")
    return np.pad(values, (0, size - values.size))
