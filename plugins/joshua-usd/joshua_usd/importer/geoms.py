"""Colliders (CollisionAPI) and visual-only shapes of each body: collider mass/density (MassAPI), friction from
the bound physics material, margin and gap from PhysX's collision offsets, displayColor; visuals get
contype = conaffinity = 0, no mass, group 2."""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdPhysics, UsdShade

from joshua_usd.importer.pose import Pose
from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.shapes import add_shape
from joshua_usd.importer.stage import StageFrame, positive, prims, read, read_physx
from joshua_usd.importer.topology import enclosing_body

VISUAL_GROUP = 2
HIDDEN_COLLIDER_GROUP = 3  # colliders that are invisible or guides: hidden in MuJoCo's viewer by default


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
        geom.group = VISUAL_GROUP
        geom.density = 0.0
        return geom
    imageable = UsdGeom.Imageable(shape.prim)
    if imageable.ComputeVisibility() == UsdGeom.Tokens.invisible or imageable.ComputePurpose() == UsdGeom.Tokens.guide:
        geom.group = HIDDEN_COLLIDER_GROUP
    _margin(geom, shape.prim, frame, report)
    material = _physics_material(shape.prim, report)
    _density(geom, shape, material, frame, report)
    if material is not None:
        geom.friction[0] = read(material, "physics:dynamicFriction", report)
    return geom


def _margin(geom: mujoco.MjsGeom, prim: Usd.Prim, frame: StageFrame, report: ImportReport) -> None:
    """PhysX's contact offset (where contacts start) as MuJoCo's margin and its rest offset (where shapes come to
    rest) as margin - gap: margin = max(contactOffset, restOffset), gap = margin - restOffset. Unauthored, -inf
    or a negative contactOffset is PhysX's automatic one: MuJoCo's margin 0."""
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
    if read(prim, "physics:restitution", report):
        report.warn(prim.GetPath(), "restitution is not supported by MuJoCo's soft contacts: ignored")
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
