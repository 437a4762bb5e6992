"""Colliders and visuals from MuJoCo geoms: USD primitives or meshes (MuJoCo's compiled vertices, in
the geom frame) under each body's `collisions` / `visuals` Xform; world geoms under the environment."""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdPhysics, Vt

from joshua_usd.exporter.context import Context, set_physx, set_pose
from joshua_usd.exporter.frames import gf_vec3f
from joshua_usd.exporter.materials import Materials

G = mujoco.mjtGeom
HIDDEN_GROUP = 3  # MuJoCo's viewer hides geom groups 3-5 by default: their prims get purpose "guide"
PLANE_EXTENT = 100.0  # rendered size (m) of an infinite MuJoCo plane; the PhysX plane is infinite anyway


def write_geoms(ctx: Context) -> None:
    """Every geom with contype or conaffinity set becomes a collider (it also renders unless its group
    is hidden), every other geom a visual; each gets its look, colliders also their friction."""
    model = ctx.model
    materials = Materials(ctx)
    groups: dict[tuple[int, bool], Sdf.Path] = {}
    for geom in range(model.ngeom):
        body = int(model.geom_bodyid[geom])
        collider = bool(model.geom_contype[geom] or model.geom_conaffinity[geom])
        kind = G(model.geom_type[geom])
        label = kind.name[len("mjGEOM_") :].lower()
        if kind == G.mjGEOM_MESH:
            label = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_MESH, model.geom_dataid[geom]) or label
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, geom) or label
        if kind not in SHAPES or (kind == G.mjGEOM_PLANE and body):
            where = " on moving bodies" if body else ""
            ctx.note(f"geom '{name}': {kind.name[len('mjGEOM_') :].lower()} geoms{where} are not exported")
            continue
        parent = _group(ctx, groups, body, collider)
        prim = SHAPES[kind](ctx, ctx.child_path(parent, name), geom)
        scale = model.geom_size[geom] if kind == G.mjGEOM_BOX else None
        set_pose(prim, model.geom_pos[geom], model.geom_quat[geom], scale)
        gprim = UsdGeom.Gprim(prim)
        gprim.CreateDisplayColorAttr(Vt.Vec3fArray([gf_vec3f(_rgba(model, geom)[:3])]))
        if model.geom_group[geom] >= HIDDEN_GROUP:
            gprim.CreatePurposeAttr(UsdGeom.Tokens.guide)
        extent = UsdGeom.Boundable.ComputeExtentFromPlugins(gprim, Usd.TimeCode.Default())
        if extent:
            gprim.CreateExtentAttr(extent)
        materials.bind_look(prim, geom)
        if collider:
            ctx.collider_paths[geom] = prim.GetPath()
            _collider(ctx, prim, geom, name)
            materials.bind_friction(prim, geom)


def _collider(ctx: Context, prim: Usd.Prim, geom: int, name: str) -> None:
    """CollisionAPI (meshes collide as their convex hull, as in MuJoCo); a MuJoCo margin becomes PhysX's
    restOffset margin - gap: the distance where MuJoCo's contact force starts, where PhysX shapes rest;
    with a gap, contactOffset = margin, where both start generating contacts."""
    model = ctx.model
    UsdPhysics.CollisionAPI.Apply(prim)
    if model.geom_type[geom] == G.mjGEOM_MESH:
        UsdPhysics.MeshCollisionAPI.Apply(prim).CreateApproximationAttr(UsdPhysics.Tokens.convexHull)
    margin, gap = float(model.geom_margin[geom]), float(model.geom_gap[geom])
    if margin > 0:
        set_physx(prim, "PhysxCollisionAPI", "restOffset", Sdf.ValueTypeNames.Float, margin - gap)
        if gap > 0:  # PhysX needs contactOffset > restOffset
            set_physx(prim, "PhysxCollisionAPI", "contactOffset", Sdf.ValueTypeNames.Float, margin)
    if model.geom_condim[geom] > 3:
        ctx.note(f"geom '{name}': condim {model.geom_condim[geom]} (torsional and rolling friction)")


def _rgba(model: mujoco.MjModel, geom: int) -> np.ndarray:
    matid = model.geom_matid[geom]
    return model.mat_rgba[matid] if matid >= 0 else model.geom_rgba[geom]


def _group(ctx: Context, groups: dict[tuple[int, bool], Sdf.Path], body: int, collider: bool) -> Sdf.Path:
    """The Xform that holds a body's colliders or visuals (the environment Xform for world geoms)."""
    if not body:
        return ctx.parent_path(body)
    key = (body, collider)
    if key not in groups:
        groups[key] = ctx.child_path(ctx.body_paths[body], "collisions" if collider else "visuals")
        UsdGeom.Xform.Define(ctx.stage, groups[key])
    return groups[key]


def _box(ctx: Context, path: Sdf.Path, geom: int) -> Usd.Prim:
    """A cube of size 2 scaled by the half sizes (the scale op is added with the pose)."""
    cube = UsdGeom.Cube.Define(ctx.stage, path)
    cube.CreateSizeAttr(2.0)
    return cube.GetPrim()


def _sphere(ctx: Context, path: Sdf.Path, geom: int) -> Usd.Prim:
    sphere = UsdGeom.Sphere.Define(ctx.stage, path)
    sphere.CreateRadiusAttr(float(ctx.model.geom_size[geom, 0]))
    return sphere.GetPrim()


def _round(schema: type[UsdGeom.Capsule] | type[UsdGeom.Cylinder]) -> Callable[[Context, Sdf.Path, int], Usd.Prim]:
    """A capsule's or cylinder's writer: along the geom's z axis, USD's height the cylinder part only (twice
    MuJoCo's size[1], the half-length), the radius MuJoCo's size[0]."""

    def define(ctx: Context, path: Sdf.Path, geom: int) -> Usd.Prim:
        shape = schema.Define(ctx.stage, path)
        shape.CreateAxisAttr(UsdGeom.Tokens.z)
        shape.CreateRadiusAttr(float(ctx.model.geom_size[geom, 0]))
        shape.CreateHeightAttr(float(2 * ctx.model.geom_size[geom, 1]))
        return shape.GetPrim()

    return define


def _plane(ctx: Context, path: Sdf.Path, geom: int) -> Usd.Prim:
    """A UsdGeom.Plane with normal +z (PhysX collides it as an infinite plane); a MuJoCo plane of size
    0 (infinite) is drawn PLANE_EXTENT wide."""
    plane = UsdGeom.Plane.Define(ctx.stage, path)
    plane.CreateAxisAttr(UsdGeom.Tokens.z)
    width, length = (2 * s if s > 0 else PLANE_EXTENT for s in ctx.model.geom_size[geom, :2])
    plane.CreateWidthAttr(float(width))
    plane.CreateLengthAttr(float(length))
    return plane.GetPrim()


def _mesh(ctx: Context, path: Sdf.Path, geom: int) -> Usd.Prim:
    """MuJoCo's compiled mesh (recentred and scaled, so in the geom frame) as a triangle mesh."""
    model = ctx.model
    mesh_id = model.geom_dataid[geom]
    start, count = model.mesh_vertadr[mesh_id], model.mesh_vertnum[mesh_id]
    first, faces = model.mesh_faceadr[mesh_id], model.mesh_facenum[mesh_id]
    mesh = UsdGeom.Mesh.Define(ctx.stage, path)
    points = np.ascontiguousarray(model.mesh_vert[start : start + count], np.float32)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray([3] * int(faces)))
    indices = np.ascontiguousarray(model.mesh_face[first : first + faces].ravel(), np.int32)
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(indices))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    return mesh.GetPrim()


SHAPES = {
    G.mjGEOM_BOX: _box,
    G.mjGEOM_SPHERE: _sphere,
    G.mjGEOM_CAPSULE: _round(UsdGeom.Capsule),
    G.mjGEOM_CYLINDER: _round(UsdGeom.Cylinder),
    G.mjGEOM_PLANE: _plane,
    G.mjGEOM_MESH: _mesh,
}
