"""Helpers building real UsdPhysics stages with pxr for the importer tests, and reading poses back with Gf
(independently of the importer's numpy/MuJoCo math)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdPhysics

NO_ROTATION = Gf.Rotation(Gf.Vec3d(1, 0, 0), 0)  # the identity: joint()'s default frame orientation


def new_stage(path: Path, up: str = "Z", meters_per_unit: float = 1.0) -> Usd.Stage:
    """A new stage file with a PhysicsScene and a /World default prim."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, up)
    UsdGeom.SetStageMetersPerUnit(stage, meters_per_unit)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, "/World").GetPrim())
    UsdPhysics.Scene.Define(stage, "/World/physicsScene")
    return stage


def place(
    prim: Usd.Prim,
    position: Sequence[float] = (0, 0, 0),
    rotation: Gf.Rotation | None = None,
    scale: Sequence[float] | None = None,
) -> None:
    """Author translate / orient / scale ops on a prim."""
    xform = UsdGeom.Xformable(prim)
    xform.AddTranslateOp().Set(Gf.Vec3d(*position))
    if rotation is not None:
        xform.AddOrientOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Quatd(rotation.GetQuat()))
    if scale is not None:
        xform.AddScaleOp().Set(Gf.Vec3f(*scale))


def body(
    stage: Usd.Stage,
    path: str,
    position: Sequence[float] = (0, 0, 0),
    rotation: Gf.Rotation | None = None,
    size: float = 0.1,
) -> Usd.Prim:
    """A rigid body Xform with a cube collider child `<path>/box` of edge `size`."""
    prim = UsdGeom.Xform.Define(stage, path).GetPrim()
    place(prim, position, rotation)
    UsdPhysics.RigidBodyAPI.Apply(prim)
    cube = UsdGeom.Cube.Define(stage, f"{path}/box")
    cube.CreateSizeAttr(size)
    UsdPhysics.CollisionAPI.Apply(cube.GetPrim())
    return prim


def world_matrix(prim: Usd.Prim | None) -> Gf.Matrix4d:
    """The prim's local-to-world matrix (identity for the world)."""
    if prim is None:
        return Gf.Matrix4d(1)
    return UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default())


def joint(
    stage: Usd.Stage,
    schema: type,
    path: str,
    body0: Usd.Prim | None,
    body1: Usd.Prim,
    world_position: Sequence[float],
    world_rotation: Gf.Rotation = NO_ROTATION,
    axis: str = "X",
) -> Usd.Prim:
    """A joint whose frame sits at `world_position`/`world_rotation`, written as localPos/localRot of both
    bodies the way Isaac's importers do (consistent with the bodies' world transforms)."""
    made = schema.Define(stage, path)
    if body0 is not None:
        made.CreateBody0Rel().SetTargets([body0.GetPath()])
    made.CreateBody1Rel().SetTargets([body1.GetPath()])
    for index, end in (("0", body0), ("1", body1)):
        local_pos, local_rot = joint_local(end, world_position, world_rotation)
        made.GetPrim().GetAttribute(f"physics:localPos{index}").Set(local_pos)
        made.GetPrim().GetAttribute(f"physics:localRot{index}").Set(local_rot)
    if hasattr(made, "CreateAxisAttr"):
        made.CreateAxisAttr(axis)
    return made.GetPrim()


def joint_local(
    end: Usd.Prim | None, world_position: Sequence[float], world_rotation: Gf.Rotation
) -> tuple[Gf.Vec3f, Gf.Quatf]:
    """The joint frame in a body's local coordinates (scale included), from its world pose."""
    matrix = world_matrix(end)
    local_pos = matrix.GetInverse().Transform(Gf.Vec3d(*world_position))
    body_rotation = matrix.ExtractRotation()
    local_rot = (world_rotation * body_rotation.GetInverse()).GetQuat()  # Gf: a * b applies a first
    return Gf.Vec3f(local_pos), Gf.Quatf(local_rot)


def to_mujoco(stage: Usd.Stage, point: Gf.Vec3d, direction: bool = False) -> np.ndarray:
    """A stage point (or direction) in MuJoCo's world: metres, Z up."""
    scale = 1.0 if direction else UsdGeom.GetStageMetersPerUnit(stage)
    x, y, z = (scale * value for value in point)
    return np.array([x, -z, y] if UsdGeom.GetStageUpAxis(stage) == "Y" else [x, y, z])
