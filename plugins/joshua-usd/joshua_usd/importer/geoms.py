"""Colliders (CollisionAPI) and visual-only shapes of each body: collider mass/density (MassAPI), friction from
the bound physics material (torsional and rolling from NewtonMaterialAPI, else MjcMaterialAPI), margin and gap from
NewtonCollisionAPI (else MjcCollisionAPI, else PhysX's collision offsets), MuJoCo's contact settings from
MjcCollisionAPI, displayColor; visuals get contype = conaffinity = 0, no mass, group 2 (or MjcImageableAPI's
mjc:group)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdPhysics, UsdShade

from joshua_usd.importer.pose import Pose
from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.shapes import add_shape
from joshua_usd.importer.stage import StageFrame, positive, prims, read, read_array, read_number, read_physx
from joshua_usd.importer.topology import enclosing_body
from joshua_usd.physx_schema import attribute_name

VISUAL_GROUP = 2
HIDDEN_COLLIDER_GROUP = 3  # colliders that are invisible or guides: hidden in MuJoCo's viewer by default
# MjcCollisionAPI's contact settings, copied as authored: (attribute, MjsGeom field, array size or 0 for a number).
MJC_CONTACT = (
    ("mjc:condim", "condim", 0),
    ("mjc:priority", "priority", 0),
    ("mjc:solmix", "solmix", 0),
    ("mjc:solref", "solref", mujoco.mjNREF),
    ("mjc:solimp", "solimp", mujoco.mjNIMP),
    ("mjc:group", "group", 0),
)
# (Newton's name, MuJoCo's deprecated one) of torsional and rolling friction: MuJoCo's friction[1] and [2].
SPIN_FRICTION = (
    ("newton:torsionalFriction", "mjc:torsionalfriction"),
    ("newton:rollingFriction", "mjc:rollingfriction"),
)


@dataclass(frozen=True)
class Shape:
    """A shape prim, the rigid body it moves with (None: the world) and whether it collides."""

    prim: Usd.Prim
    owner: Usd.Prim | None
    collider: bool


def shapes(stage: Usd.Stage, bodies: set[Sdf.Path], report: ImportReport) -> list[Shape]:
    """Every collider and every rendered shape, each with its nearest rigid-body ancestor (or itself)."""
    found = []
    for prim in prims(stage):
        if not prim.IsA(UsdGeom.Gprim):
            continue
        collider = prim.HasAPI(UsdPhysics.CollisionAPI) and read(prim, "physics:collisionEnabled", report) is not False
        imageable = UsdGeom.Imageable(prim)
        rendered = imageable.ComputePurpose() in (UsdGeom.Tokens.default_, UsdGeom.Tokens.render)
        if collider or (rendered and imageable.ComputeVisibility() != UsdGeom.Tokens.invisible):
            found.append(Shape(prim, enclosing_body(prim, bodies), collider))
    return found


def add_geom(
    spec: mujoco.MjSpec,
    body: mujoco.MjsBody,
    body_pose: Pose,
    shape: Shape,
    name: str,
    frame: StageFrame,
    report: ImportReport,
) -> mujoco.MjsGeom | None:
    """Add one shape to `body` (whose stage pose is `body_pose`) as a collider or a massless visual."""
    in_body = body_pose.inverse().matrix() @ frame.world_matrix(shape.prim)
    geom = add_shape(spec, body, shape.prim, in_body, name, shape.collider, report)
    if geom is None:
        return None
    _color(geom, shape.prim, report)
    if not shape.collider:
        geom.contype = geom.conaffinity = 0
        group = read_number(shape.prim, "mjc:group", report, authored=True, integer=True)  # MjcImageableAPI's
        geom.group = VISUAL_GROUP if group is None else int(group)
        geom.density = 0.0
        return geom
    imageable = UsdGeom.Imageable(shape.prim)
    if imageable.ComputeVisibility() == UsdGeom.Tokens.invisible or imageable.ComputePurpose() == UsdGeom.Tokens.guide:
        geom.group = HIDDEN_COLLIDER_GROUP
    _margin(geom, shape.prim, frame, report)
    _mjc_contact(geom, shape.prim, report)
    material = _physics_material(shape.prim, report)
    _density(geom, shape, material, frame, report)
    if material is not None:
        geom.friction[0] = read(material, "physics:dynamicFriction", report)
        for index, names in enumerate(SPIN_FRICTION, start=1):
            value = next(
                (found for name in names if (found := read_number(material, name, report, authored=True)) is not None),
                None,
            )
            if value is not None:
                geom.friction[index] = positive(material, names[0], value, report)
    return geom


def _mjc_contact(geom: mujoco.MjsGeom, prim: Usd.Prim, report: ImportReport) -> None:
    """MjcCollisionAPI's condim, priority, solmix, solref, solimp and group, where authored."""
    for attribute, field, size in MJC_CONTACT:
        value: np.ndarray | float | None
        if size:
            value = read_array(prim, attribute, size, report)
        else:
            value = read_number(prim, attribute, report, authored=True, integer=field != "solmix")
        if value is not None:
            setattr(geom, field, value)


def _margin(geom: mujoco.MjsGeom, prim: Usd.Prim, frame: StageFrame, report: ImportReport) -> None:
    """MuJoCo's margin and gap: newton:contactMargin and newton:contactGap (stage lengths; a gap of -inf is the
    engine's own, MuJoCo's 0), else MjcCollisionAPI's mjc:margin and mjc:gap (metres), as mujoco-usd-converter maps
    MuJoCo's to them; where none is authored, PhysX's contact offset (where contacts start) as the margin and its
    rest offset (where shapes come to rest) as margin - gap: margin = max(contactOffset, restOffset), gap = margin -
    restOffset. Unauthored, -inf or a negative contactOffset is PhysX's automatic one: MuJoCo's margin 0."""
    solver = [
        next((value * scale for name, scale in names if (value := _length(prim, name, report)) is not None), None)
        for names in (
            (("newton:contactMargin", frame.meters_per_unit), ("mjc:margin", 1.0)),
            (("newton:contactGap", frame.meters_per_unit), ("mjc:gap", 1.0)),
        )
    ]
    if solver != [None, None]:
        geom.margin, geom.gap = (value or 0.0 for value in solver)
        return
    offsets = [
        read_physx(prim, "PhysxCollisionAPI", f"{name}Offset", report, allow_inf=True) for name in ("rest", "contact")
    ]
    rest, contact = (value if value is not None and math.isfinite(value) else None for value in offsets)
    if contact is not None and contact < 0:
        contact = None
    if rest is None and contact is None:
        return
    rest = 0.0 if rest is None else float(rest)
    margin = max(rest, rest if contact is None else float(contact))
    geom.margin = margin * frame.meters_per_unit
    geom.gap = (margin - rest) * frame.meters_per_unit


def _length(prim: Usd.Prim, name: str, report: ImportReport) -> float | None:
    """An authored margin or gap: None when unauthored, 0 for -inf (the engine's default); negative is a
    ModelError."""
    value = read_number(prim, name, report, authored=True, allow_inf=True)
    if value is None or value == -math.inf:
        return None if value is None else 0.0
    return positive(prim, name, value, report)


def _color(geom: mujoco.MjsGeom, prim: Usd.Prim, report: ImportReport) -> None:
    """displayColor (and displayOpacity) of the prim, first value, as the geom's rgba."""
    color = read(prim, "primvars:displayColor", report)
    if color is not None and len(color):
        opacity = read(prim, "primvars:displayOpacity", report)
        alpha = float(opacity[0]) if opacity is not None and len(opacity) else 1.0
        geom.rgba = [*np.asarray(color[0], dtype=np.float64), alpha]


def _physics_material(prim: Usd.Prim, report: ImportReport) -> Usd.Prim | None:
    """The prim of the physics material bound to a collider (material:binding:physics, inherited), if any,
    warning once per material about what MuJoCo's single friction coefficient drops."""
    material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial("physics")
    if not material or not material.GetPrim().HasAPI(UsdPhysics.MaterialAPI):
        return None
    prim = material.GetPrim()
    dynamic, static = (read(prim, f"physics:{kind}Friction", report) for kind in ("dynamic", "static"))
    for name, value in (("dynamicFriction", dynamic), ("staticFriction", static)):
        if value < 0:
            raise report.error(prim.GetPath(), f"physics:{name}", f"friction must not be negative, got {value}")
    if abs(static - dynamic) > 1e-9:
        report.warn(
            prim.GetPath(),
            f"staticFriction {static:.6g} differs from dynamicFriction {dynamic:.6g}: MuJoCo uses dynamicFriction",
        )
        report.ignore(prim.GetPath(), "physics:staticFriction")
    if read(prim, "physics:restitution", report):
        report.warn(prim.GetPath(), "restitution is not supported by MuJoCo's soft contacts: ignored")
        report.ignore(prim.GetPath(), "physics:restitution")
    mode = read_physx(prim, "PhysxMaterialAPI", "frictionCombineMode", report)
    if mode is not None and str(mode) != "max":
        report.warn(prim.GetPath(), f"frictionCombineMode {mode}: MuJoCo combines by the larger friction (max)")
        report.ignore(prim.GetPath(), attribute_name("PhysxMaterialAPI", "frictionCombineMode"))
    return prim


def _density(
    geom: mujoco.MjsGeom, shape: Shape, material: Usd.Prim | None, frame: StageFrame, report: ImportReport
) -> None:
    """A collider's mass (its MassAPI mass) or density: its own, else its body's, else its material's, else 1000."""
    sources = [shape.prim] if shape.prim.HasAPI(UsdPhysics.MassAPI) else []
    mass = read(shape.prim, "physics:mass", report) if sources else None
    if mass:
        geom.mass = positive(shape.prim, "physics:mass", mass, report) * frame.kilograms_per_unit
        return
    sources += [shape.owner] if shape.owner is not None and shape.owner.HasAPI(UsdPhysics.MassAPI) else []
    sources += [material] if material is not None else []
    for source in sources:
        density = read(source, "physics:density", report)
        if density:
            density = positive(source, "physics:density", density, report)
            geom.density = density * frame.kilograms_per_unit / frame.meters_per_unit**3
            return
