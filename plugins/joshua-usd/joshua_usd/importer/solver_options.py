"""MuJoCo's solver options on the PhysicsScene: MjcSceneAPI's `mjc:option:*`, `mjc:flag:*` and the compiler settings
the importer can honour (`mjc:compiler:angle`, `mjc:compiler:autoLimits`), then the exporter's `joshua:option:*`
(integrator, cone, impratio) where MjcSceneAPI authors none. Values are MuJoCo's, in its units, as authored."""

from __future__ import annotations

import math

import mujoco
from pxr import Usd

from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.stage import read, read_array, read_authored, read_number

OPTION_PREFIX = "mjc:option:"
JOSHUA_PREFIX = "joshua:option:"  # what the exporter writes: MuJoCo settings UsdPhysics has no attribute for
# Enumerated options: (name, mjOption field, MuJoCo enum, its prefix). The token is the member's name, lower case.
TOKENS = (
    ("integrator", "integrator", mujoco.mjtIntegrator, "mjINT_"),
    ("cone", "cone", mujoco.mjtCone, "mjCONE_"),
    ("jacobian", "jacobian", mujoco.mjtJacobian, "mjJAC_"),
    ("solver", "solver", mujoco.mjtSolver, "mjSOL_"),
)
# Numeric options: (name, field, whole number, must be positive).
NUMBERS = (
    ("impratio", "impratio", False, True),
    ("tolerance", "tolerance", False, False),
    ("ls_iterations", "ls_iterations", True, False),
    ("ls_tolerance", "ls_tolerance", False, False),
    ("noslip_iterations", "noslip_iterations", True, False),
    ("noslip_tolerance", "noslip_tolerance", False, False),
    ("ccd_iterations", "ccd_iterations", True, False),
    ("ccd_tolerance", "ccd_tolerance", False, False),
    ("sdf_iterations", "sdf_iterations", True, False),
    ("sdf_initpoints", "sdf_initpoints", True, False),
    ("density", "density", False, False),
    ("viscosity", "viscosity", False, False),
    ("o_margin", "o_margin", False, False),
)
ARRAYS = (
    ("wind", "wind", 3),
    ("magnetic", "magnetic", 3),
    ("o_solref", "o_solref", mujoco.mjNREF),
    ("o_solimp", "o_solimp", mujoco.mjNIMP),
    ("o_friction", "o_friction", 5),
)
DEGREE = math.pi / 180


def angle_unit(scene: Usd.Prim | None, report: ImportReport) -> float:
    """Radians per unit of MuJoCo's angles in mjc:* attributes: `mjc:compiler:angle` "radian" or, as MjcSceneAPI's
    fallback (and MJCF's), "degree"."""
    if scene is None:
        return DEGREE
    token = read_authored(scene, "mjc:compiler:angle", report)
    if token is None or str(token) == "degree":
        return DEGREE
    if str(token) == "radian":
        return 1.0
    raise report.error(scene.GetPath(), "mjc:compiler:angle", f"must be degree or radian, got {token}")


def set_solver_options(spec: mujoco.MjSpec, scene: Usd.Prim, report: ImportReport) -> None:
    """Copy the scene's authored mjc:option:*, mjc:flag:* and mjc:compiler:autoLimits onto `spec`, and the
    exporter's joshua:option:* where no mjc:option:* of the same name is authored."""
    for name, field, enum, prefix in TOKENS:
        attribute = OPTION_PREFIX + name
        token = read_authored(scene, attribute, report)
        if token is None and name in ("integrator", "cone"):
            attribute = JOSHUA_PREFIX + name
            token = read(scene, attribute, report)
        if token is None:
            continue
        member = getattr(enum, prefix + str(token).upper(), None)
        if member is None:
            report.warn(scene.GetPath(), f"{attribute} {token!r} is not a MuJoCo {name}: ignored")
            report.ignore(scene.GetPath(), attribute)
        else:
            setattr(spec.option, field, member)
    for name, field, integer, positive in NUMBERS:
        attribute = OPTION_PREFIX + name
        value = read_number(scene, attribute, report, integer=integer, authored=True)
        if value is None and name == "impratio":
            attribute = JOSHUA_PREFIX + name
            value = read_number(scene, attribute, report)
        if value is None:
            continue
        if value < 0 or (positive and value == 0):
            need = "positive" if positive else "not negative"
            raise report.error(scene.GetPath(), attribute, f"must be {need}, got {value}")
        setattr(spec.option, field, value)
    for name, field, size in ARRAYS:
        values = read_array(scene, OPTION_PREFIX + name, size, report)
        if values is not None:
            setattr(spec.option, field, values)
    groups = read_authored(scene, OPTION_PREFIX + "actuatorgroupdisable", report)
    if groups is not None:
        spec.option.disableactuator = sum(1 << int(group) for group in groups if 0 <= int(group) < 31)
    _flags(spec, scene, report)
    autolimits = read_number(scene, "mjc:compiler:autoLimits", report, authored=True)
    if autolimits is not None:
        spec.compiler.autolimits = bool(autolimits)


def _flags(spec: mujoco.MjSpec, scene: Usd.Prim, report: ImportReport) -> None:
    """mjc:flag:<name>: false sets MuJoCo's disable bit mjDSBL_<NAME>, true sets its enable bit mjENBL_<NAME>;
    the other values leave MuJoCo's default. A name MuJoCo does not know is warned about. The deprecated
    mjc:flag:gravity gives way to newton:gravityEnabled (scene.py)."""
    newton_gravity = scene.GetAttribute("newton:gravityEnabled").HasAuthoredValue()
    for attribute in scene.GetAuthoredAttributes():
        full = attribute.GetName()
        if not full.startswith("mjc:flag:") or (full == "mjc:flag:gravity" and newton_gravity):
            continue
        name = full.removeprefix("mjc:flag:").upper()
        value = bool(read_number(scene, full, report, authored=True))
        disable = getattr(mujoco.mjtDisableBit, f"mjDSBL_{name}", None)
        enable = getattr(mujoco.mjtEnableBit, f"mjENBL_{name}", None)
        if disable is not None:
            spec.option.disableflags = _bit(spec.option.disableflags, int(disable), not value)
        elif enable is not None:
            spec.option.enableflags = _bit(spec.option.enableflags, int(enable), value)
        else:
            report.warn(scene.GetPath(), f"{full} is not a MuJoCo flag: ignored")
            report.ignore(scene.GetPath(), full)


def _bit(flags: int, bit: int, on: bool) -> int:
    """`flags` with `bit` set or cleared."""
    return flags | bit if on else flags & ~bit
