"""UsdGeom shapes as MuJoCo geoms: Cube, Sphere, Capsule, Cylinder, Plane and Mesh (with its
MeshCollisionAPI approximation), sized by the prim's scale in its body's frame."""

from __future__ import annotations

import math

import mujoco
import numpy as np
from numpy.typing import NDArray
from pxr import Usd, UsdGeom, UsdPhysics

from joshua_usd.importer.pose import Pose, Vec, axis_angle, decompose, matrix_quat, rotate
from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.stage import read

GeomType = mujoco.mjtGeom
# Rotations taking MuJoCo's z-aligned capsule/cylinder/plane normal onto a USD `axis`.
AXIS_TURN = {"X": axis_angle([0, 1, 0], math.pi / 2), "Y": axis_angle([1, 0, 0], -math.pi / 2), "Z": np.eye(4)[0]}
AXIS_INDEX = {"X": 0, "Y": 1, "Z": 2}
# Mesh approximations MuJoCo collides exactly as asked; any other uses the mesh's convex hull (warned).
EXACT_APPROXIMATIONS = {"convexHull", "boundingCube", "boundingSphere"}
FLAT_RATIO = 1e-9  # points whose thinnest spread is this small against their widest lie in a plane
THIN_HALF_THICKNESS = 5e-4  # metres: half the thickness of the box standing in for a flat collider mesh


def add_shape(
    spec: mujoco.MjSpec,
    body: mujoco.MjsBody,
    prim: Usd.Prim,
    in_body: NDArray[np.float64],
    name: str,
    collider: bool,
    report: ImportReport,
) -> mujoco.MjsGeom | None:
    """Add the geom of a shape prim whose local-to-body matrix is `in_body` (metres); None if unsupported."""
    pose, scale = decompose(in_body)
    if prim.IsA(UsdGeom.Mesh):
        return _mesh(spec, body, prim, in_body, name, collider, report)
    if prim.IsA(UsdGeom.Cube):
        size = read(prim, "size", report)
        return body.add_geom(name=name, type=GeomType.mjGEOM_BOX, pos=pose.pos, quat=pose.quat, size=size / 2 * scale)
    if prim.IsA(UsdGeom.Sphere):
        radius = read(prim, "radius", report) * scale
        kind = GeomType.mjGEOM_SPHERE if np.ptp(radius) < 1e-9 * radius.max() else GeomType.mjGEOM_ELLIPSOID
        return body.add_geom(name=name, type=kind, pos=pose.pos, quat=pose.quat, size=radius)
    if prim.IsA(UsdGeom.Capsule) or prim.IsA(UsdGeom.Cylinder):
        return _round(body, prim, pose, scale, name, report)
    if prim.IsA(UsdGeom.Plane):
        turned = pose * Pose(np.zeros(3), AXIS_TURN[str(read(prim, "axis", report))])
        return body.add_geom(name=name, type=GeomType.mjGEOM_PLANE, pos=turned.pos, quat=turned.quat, size=[0, 0, 1])
    report.warn(prim.GetPath(), f"{prim.GetTypeName()} shapes are not supported: skipped")
    return None


def _round(
    body: mujoco.MjsBody, prim: Usd.Prim, pose: Pose, scale: Vec, name: str, report: ImportReport
) -> mujoco.MjsGeom:
    """A capsule or cylinder along its `axis` attribute; height is the capsule's spine or the cylinder's length."""
    axis = str(read(prim, "axis", report))
    along = AXIS_INDEX[axis]
    across = [scale[index] for index in range(3) if index != along]
    if abs(across[0] - across[1]) > 1e-9 * max(across):
        report.warn(prim.GetPath(), "non-uniform scale across the axis: the radius uses the larger scale")
    radius = read(prim, "radius", report) * max(across)
    half = read(prim, "height", report) / 2 * scale[along]
    capsule = prim.IsA(UsdGeom.Capsule)
    kind = GeomType.mjGEOM_CAPSULE if capsule else GeomType.mjGEOM_CYLINDER
    turned = pose * Pose(np.zeros(3), AXIS_TURN[axis])
    return body.add_geom(name=name, type=kind, pos=turned.pos, quat=turned.quat, size=[radius, half, 0])


def _mesh(
    spec: mujoco.MjSpec,
    body: mujoco.MjsBody,
    prim: Usd.Prim,
    in_body: NDArray[np.float64],
    name: str,
    collider: bool,
    report: ImportReport,
) -> mujoco.MjsGeom | None:
    """A mesh geom with the vertices baked into the body frame, or the bounding box / sphere it asks for."""
    points = _array(prim, "points", report, np.float64).reshape(-1, 3)
    counts = _array(prim, "faceVertexCounts", report, np.int64)
    indices = _array(prim, "faceVertexIndices", report, np.int64)
    if len(points) < 4 or not len(counts):
        report.warn(prim.GetPath(), f"mesh with {len(points)} points and {len(counts)} faces: skipped")
        return None
    if indices.size != counts.sum() or (indices.size and (indices.min() < 0 or indices.max() >= len(points))):
        raise report.error(prim.GetPath(), "faceVertexIndices", "do not match points and faceVertexCounts")
    approximation = _approximation(prim, collider, report)
    if approximation == "boundingCube":
        pose, scale = decompose(in_body)
        low, high = (points * scale).min(axis=0), (points * scale).max(axis=0)
        center = pose.pos + rotate(pose.quat, (low + high) / 2)
        return body.add_geom(name=name, type=GeomType.mjGEOM_BOX, pos=center, quat=pose.quat, size=(high - low) / 2)
    vertices = points @ in_body[:3, :3].T + in_body[:3, 3]
    if collider and _flat(vertices):
        report.warn(prim.GetPath(), "a flat collider mesh has no convex hull in MuJoCo: a thin box instead")
        return _thin_box(body, vertices, name)
    if approximation == "boundingSphere":
        center = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
        radius = float(np.linalg.norm(vertices - center, axis=1).max())
        return body.add_geom(name=name, type=GeomType.mjGEOM_SPHERE, pos=center, size=[radius, 0, 0])
    mesh = spec.add_mesh(name=name, uservert=vertices.reshape(-1).tolist(), userface=_triangles(counts, indices))
    inertia = mujoco.mjtMeshInertia  # visual meshes may be open or flat: a shell always has an inertia
    mesh.inertia = inertia.mjMESH_INERTIA_CONVEX if collider else inertia.mjMESH_INERTIA_SHELL
    return body.add_geom(name=name, type=GeomType.mjGEOM_MESH, meshname=name)


def _flat(vertices: NDArray[np.float64]) -> bool:
    """Whether the points lie in a plane (MuJoCo cannot build their convex hull)."""
    spread = np.linalg.svd(vertices - vertices.mean(axis=0), compute_uv=False)
    return bool(spread[2] <= FLAT_RATIO * spread[0])


def _thin_box(body: mujoco.MjsBody, vertices: NDArray[np.float64], name: str) -> mujoco.MjsGeom:
    """The box bounding flat points in their plane, THIN_HALF_THICKNESS thick each side."""
    center = vertices.mean(axis=0)
    _, _, axes = np.linalg.svd(vertices - center)
    if np.linalg.det(axes) < 0:
        axes[2] = -axes[2]
    local = (vertices - center) @ axes.T
    low, high = local.min(axis=0), local.max(axis=0)
    size = np.maximum((high - low) / 2, THIN_HALF_THICKNESS)
    position = center + axes.T @ ((low + high) / 2)
    return body.add_geom(name=name, type=GeomType.mjGEOM_BOX, pos=position, quat=matrix_quat(axes.T), size=size)


def _approximation(prim: Usd.Prim, collider: bool, report: ImportReport) -> str:
    """The MeshCollisionAPI approximation of a collider mesh ("none" when unapplied), warning when MuJoCo's
    convex hull stands in for it."""
    if not collider:
        return "visual"
    approximation = "none"
    if prim.HasAPI(UsdPhysics.MeshCollisionAPI):
        approximation = str(read(prim, "physics:approximation", report))
    if approximation not in EXACT_APPROXIMATIONS:
        report.warn(prim.GetPath(), f"approximation {approximation!r}: MuJoCo collides with the mesh's convex hull")
    return approximation


def _array(prim: Usd.Prim, name: str, report: ImportReport, dtype: type) -> NDArray:
    """An array attribute as numpy (empty when unauthored)."""
    value = read(prim, name, report)
    return np.asarray(value if value is not None else [], dtype=dtype)


def _triangles(counts: NDArray[np.int64], indices: NDArray[np.int64]) -> list[int]:
    """Polygon faces as a fan of triangles (flat vertex-index list)."""
    triangles: list[int] = []
    start = 0
    for count in counts.tolist():
        face = indices[start : start + count].tolist()
        for corner in range(1, count - 1):
            triangles += [face[0], face[corner], face[corner + 1]]
        start += count
    return triangles
