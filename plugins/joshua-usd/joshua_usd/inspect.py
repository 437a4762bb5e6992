"""`joshua usd inspect FILE`: what the importer makes of a USD robot, as plain text (SI units, radians and
degrees), read back from the compiled MuJoCo model so it shows exactly what simulates, and every authored physics
attribute the import did not use, so that nothing is dropped unseen."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from pxr import Usd

from joshua_usd import physx_schema
from joshua_usd.importer import Imported, compile_spec, import_usd
from joshua_usd.importer.stage import prims

JOINT_TYPES = {0: "free", 1: "ball (spherical)", 2: "prismatic (slide)", 3: "revolute (hinge)"}
# Physics attributes: UsdPhysics' (physics:*, drive:*:physics:*, limit:*:physics:*), PhysX's (physx*:*), Newton's
# (newton:*) and MuJoCo's (mjc:*).
PHYSICS_NAMESPACES = ("newton", "mjc")
SHOWN_ITEMS = 8  # of an array value


def describe(path: Path) -> str:
    """Bodies with masses, joints with limits, drives in SI units, colliders, the check against the PhysX schemas,
    the authored physics attributes the import did not use and the import's warnings."""
    imported = import_usd(path)
    model = compile_spec(imported.spec, imported.report)
    frame = imported.frame
    stage = Usd.Stage.Open(str(path), Usd.Stage.LoadAll)
    lines = [
        f"{path}: metersPerUnit {frame.meters_per_unit:g}, kilogramsPerUnit {frame.kilograms_per_unit:g}, "
        f"upAxis {frame.up_axis} (imported in metres, kilograms, Z up)",
        f"timestep {model.opt.timestep:g} s, gravity {_vector(model.opt.gravity)} m/s^2, "
        f"solver iterations {model.opt.iterations}, integrator {_enum(mujoco.mjtIntegrator, model.opt.integrator)}, "
        f"cone {_enum(mujoco.mjtCone, model.opt.cone)}, impratio {model.opt.impratio:g}",
        *_bodies(model, imported),
        *_joints(model, imported),
        *_actuators(model),
        *_colliders(model, imported),
        *physx_check(stage),
        *unused_attributes(stage, imported.report.used),
        f"warnings ({len(imported.report.warnings)}):",
        *(f"  {warning}" for warning in imported.report.warnings),
    ]
    return "\n".join(lines)


def physx_check(stage: Usd.Stage) -> list[str]:
    """The stage's PhysX API schemas and physx* attributes against the PhysX schemas: a summary line and a line per
    problem; one line saying why where the schemas are not registered."""
    if not physx_schema.registered():
        return [f"PhysX schemas: not checked, {physx_schema.missing_reason()}"]
    problems = physx_schema.check_stage(stage)
    return [f"PhysX schemas ({len(problems)} problems):", *(f"  {problem}" for problem in problems)]


def unused_attributes(stage: Usd.Stage, used: set[tuple[str, str]]) -> list[str]:
    """A summary line and a line `PRIM: ATTRIBUTE = VALUE` per authored physics attribute of the composed stage that
    is not in `used` (the import's (prim path, attribute) pairs): what the MuJoCo model does not reflect."""
    lines = [
        f"  {prim.GetPath()}: {attribute.GetName()} = {_show(attribute.Get())}"
        for prim in prims(stage)
        for attribute in prim.GetAuthoredAttributes()
        if _physics(attribute.GetName()) and (str(prim.GetPath()), attribute.GetName()) not in used
    ]
    return [f"physics attributes not used ({len(lines)}):", *lines]


def _physics(name: str) -> bool:
    """Whether attribute `name` belongs to a physics schema (UsdPhysics, PhysX, Newton, MuJoCo)."""
    parts = name.split(":")
    return parts[0] in PHYSICS_NAMESPACES or parts[0].startswith("physx") or "physics" in parts[:-1]


def _show(value: Any) -> str:
    """An attribute value in one short line: numbers to 6 significant digits, long arrays cut."""
    if isinstance(value, float):
        return f"{value:.6g}"
    if hasattr(value, "GetReal"):
        value = [value.GetReal(), *value.GetImaginary()]
    if not isinstance(value, str) and hasattr(value, "__len__"):
        items = [_show(item) for item in list(value)[:SHOWN_ITEMS]]
        return "[" + ", ".join(items + (["..."] if len(value) > SHOWN_ITEMS else [])) + "]"
    return str(value)


def _name(model: mujoco.MjModel, kind: mujoco.mjtObj, index: int) -> str:
    return mujoco.mj_id2name(model, kind, index) or f"#{index}"


def _enum(kind: type, value: int) -> str:
    """A MuJoCo enum value as its lower-case name without the prefix (mjINT_IMPLICITFAST -> implicitfast)."""
    return kind(int(value)).name.split("_", 1)[1].lower()


def _vector(values: np.ndarray) -> str:
    return "(" + ", ".join(f"{value:.4g}" for value in values) + ")"


def _bodies(model: mujoco.MjModel, imported: Imported) -> list[str]:
    lines = [f"bodies ({model.nbody - 1}):"]
    for index in range(1, model.nbody):
        name = _name(model, mujoco.mjtObj.mjOBJ_BODY, index)
        parent = _name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.body_parentid[index]))
        base = "floating" if model.body_jntnum[index] and model.jnt_type[model.body_jntadr[index]] == 0 else ""
        lines.append(
            f"  {name}: mass {model.body_mass[index]:.6g} kg, inertia {_vector(model.body_inertia[index])} kg m^2, "
            f"parent {parent}{', ' + base if base else ''}  <{imported.report.sources['body', name]}>"
        )
    return lines


def _joints(model: mujoco.MjModel, imported: Imported) -> list[str]:
    lines = [f"joints ({model.njnt}):"]
    for index in range(model.njnt):
        kind = int(model.jnt_type[index])
        name = _name(model, mujoco.mjtObj.mjOBJ_JOINT, index)
        body = _name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.jnt_bodyid[index]))
        text = f"  {name}: {JOINT_TYPES[kind]}, body {body}"
        if kind in (2, 3):
            text += f", axis {_vector(model.jnt_axis[index])}"
        if model.jnt_limited[index]:
            low, high = model.jnt_range[index]
            if kind == 2:
                text += f", limits [{low:.6g}, {high:.6g}] m"
            else:
                degrees = f"[{math.degrees(low):.6g}, {math.degrees(high):.6g}] deg"
                text += f", limits [{low:.6g}, {high:.6g}] rad = {degrees}"
        if kind in (1, 2, 3):
            text += _passive(model, index)
        source = imported.report.sources.get(("joint", name))
        lines.append(text + (f"  <{source}>" if source else ""))
    return lines


def _passive(model: mujoco.MjModel, joint: int) -> str:
    """Armature, damping and frictionloss of a hinge, slide or ball joint, where set, in SI units."""
    dof = model.jnt_dofadr[joint]
    force, position, inertia = ("N", "m", "kg") if model.jnt_type[joint] == 2 else ("N m", "rad", "kg m^2")
    units = {"armature": inertia, "damping": f"{force} s/{position}", "frictionloss": force}
    values = {name: getattr(model, f"dof_{name}")[dof] for name in units}
    return "".join(f", {name} {value:.6g} {units[name]}" for name, value in values.items() if value)


def _actuators(model: mujoco.MjModel) -> list[str]:
    lines = [f"drives ({model.nu}):"]
    for index in range(model.nu):
        if model.actuator_trntype[index] == mujoco.mjtTrn.mjTRN_BODY:
            body = model.body(model.actuator_trnid[index, 0]).name
            lines.append(f"  {_name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, index)}: adhesion on body {body}")
            continue
        joint = int(model.actuator_trnid[index, 0])
        slide = model.jnt_type[joint] == 2
        force, position = ("N", "m") if slide else ("N m", "rad")
        kp, kv = model.actuator_gainprm[index, 0], -model.actuator_biasprm[index, 2]
        kind = "position" if model.actuator_biasprm[index, 1] else "velocity" if kv else "motor"
        text = f"  {_name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, index)}: {kind}"
        if kind == "position":
            text += f", kp {kp:.6g} {force}/{position}, kv {kv:.6g} {force} s/{position}"
        elif kind == "velocity":
            text += f", kv {kp:.6g} {force} s/{position}"
        gear = model.actuator_gear[index, 0]
        if gear != 1:
            text += f", gear {gear:.6g}"
        if model.actuator_ctrllimited[index]:
            text += f", ctrl range {_vector(model.actuator_ctrlrange[index])}"
        if model.actuator_forcelimited[index]:
            text += f", max force {model.actuator_forcerange[index, 1] * abs(gear):.6g} {force} at the joint"
        lines.append(text)
    return lines


def _colliders(model: mujoco.MjModel, imported: Imported) -> list[str]:
    lines = []
    for index in range(model.ngeom):
        if not (model.geom_contype[index] or model.geom_conaffinity[index]):
            continue
        name = _name(model, mujoco.mjtObj.mjOBJ_GEOM, index)
        kind = mujoco.mjtGeom(int(model.geom_type[index])).name.removeprefix("mjGEOM_").lower()
        body = _name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.geom_bodyid[index]))
        lines.append(
            f"  {name}: {kind}, body {body}, size {_vector(model.geom_size[index])} m, "
            f"friction {model.geom_friction[index, 0]:.4g}{_margin(model, index)}  "
            f"<{imported.report.sources['geom', name]}>"
        )
    visuals = model.ngeom - len(lines)
    return [f"colliders ({len(lines)}, plus {visuals} visual-only geoms):", *lines]


def _margin(model: mujoco.MjModel, geom: int) -> str:
    """MuJoCo's contact margin and gap of a collider, where set."""
    margin, gap = model.geom_margin[geom], model.geom_gap[geom]
    return (f", margin {margin:.4g} m" if margin else "") + (f", gap {gap:.4g} m" if gap else "")
