"""Importer geometry: primitive colliders with scale and axis, mesh approximations, visual-only geoms, and
colliders that come through references, payloads, sublayers, variants and instancing."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdPhysics

sys.path.insert(0, str(Path(__file__).parent))

from usd_stages import body, new_stage, place, to_mujoco, world_matrix  # noqa: E402

from joshua_usd.importer import import_usd  # noqa: E402

GEOM = mujoco.mjtGeom


def forward(path: Path) -> tuple[mujoco.MjModel, mujoco.MjData, list[str]]:
    imported = import_usd(path)
    model = imported.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data, imported.report.warnings


def collider(stage: Usd.Stage, schema: type, path: str, **attributes: object) -> Usd.Prim:
    prim = schema.Define(stage, path).GetPrim()
    for name, value in attributes.items():
        prim.GetAttribute(name).Set(value)
    UsdPhysics.CollisionAPI.Apply(prim)
    return prim


def test_primitives_with_scale_and_axis(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "shapes.usda", "Y", 0.01)
    part = body(stage, "/World/part", (0, 100, 0), Gf.Rotation(Gf.Vec3d(0, 0, 1), 20), size=10)
    box = collider(stage, UsdGeom.Cube, "/World/part/block", size=4.0)
    place(box, (10, 0, 0), scale=(1, 2, 3))
    collider(stage, UsdGeom.Sphere, "/World/part/ball", radius=3.0)
    capsule = collider(stage, UsdGeom.Capsule, "/World/part/rod", radius=1.0, height=8.0, axis="X")
    place(capsule, (0, 10, 0))
    cylinder = collider(stage, UsdGeom.Cylinder, "/World/part/drum", radius=2.0, height=6.0, axis="Y")
    place(cylinder, (0, 0, 10), Gf.Rotation(Gf.Vec3d(1, 0, 0), 30))
    stage.Save()
    model, data, _ = forward(tmp_path / "shapes.usda")
    assert model.geom("block").type == GEOM.mjGEOM_BOX
    np.testing.assert_allclose(model.geom("block").size, [0.02, 0.04, 0.06], atol=1e-9)
    assert model.geom("ball").type == GEOM.mjGEOM_SPHERE and model.geom("ball").size[0] == pytest.approx(0.03)
    np.testing.assert_allclose(model.geom("rod").size[:2], [0.01, 0.04])
    np.testing.assert_allclose(model.geom("drum").size[:2], [0.02, 0.03])
    assert part.GetPath() == "/World/part" and model.geom("ball").bodyid[0] == model.body("part").id
    for name, axis in (("rod", (1, 0, 0)), ("drum", (0, 1, 0)), ("block", None)):
        matrix = world_matrix(stage.GetPrimAtPath(f"/World/part/{name}"))
        np.testing.assert_allclose(data.geom(name).xpos, to_mujoco(stage, matrix.ExtractTranslation()), atol=1e-7)
        if axis is not None:  # MuJoCo's capsule/cylinder z is the USD axis in the world
            expected = to_mujoco(stage, matrix.TransformDir(Gf.Vec3d(*axis)).GetNormalized(), direction=True)
            np.testing.assert_allclose(data.geom(name).xmat.reshape(3, 3)[:, 2], expected, atol=1e-6)


def tetrahedron_mesh(stage: Usd.Stage, path: str, approximation: str | None) -> Usd.Prim:
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([(0, 0, 0), (0.2, 0, 0), (0, 0.1, 0), (0, 0, 0.4)])
    mesh.CreateFaceVertexCountsAttr([3, 3, 3, 3])
    mesh.CreateFaceVertexIndicesAttr([0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3])
    UsdPhysics.CollisionAPI.Apply(mesh.GetPrim())
    if approximation is not None:
        UsdPhysics.MeshCollisionAPI.Apply(mesh.GetPrim()).CreateApproximationAttr(approximation)
    return mesh.GetPrim()


def test_mesh_collision_approximations(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "meshes.usda")
    body(stage, "/World/part")
    kinds = {
        "hull": "convexHull",
        "raw": None,
        "decomposed": "convexDecomposition",
        "cube": "boundingCube",
        "ball": "boundingSphere",
    }
    for name, approximation in kinds.items():
        tetrahedron_mesh(stage, f"/World/part/{name}", approximation)
    stage.Save()
    model, data, warnings = forward(tmp_path / "meshes.usda")
    for name in ("hull", "raw", "decomposed"):
        assert model.geom(name).type == GEOM.mjGEOM_MESH
    assert {w.split(":")[0] for w in warnings} == {"/World/part/raw", "/World/part/decomposed"}
    assert model.geom("cube").type == GEOM.mjGEOM_BOX
    np.testing.assert_allclose(model.geom("cube").size, [0.1, 0.05, 0.2])
    np.testing.assert_allclose(data.geom("cube").xpos, [0.1, 0.05, 0.2])
    assert model.geom("ball").type == GEOM.mjGEOM_SPHERE
    assert model.geom("ball").size[0] == pytest.approx(math.sqrt(0.1**2 + 0.05**2 + 0.2**2))


def test_visual_only_geometry_renders_without_colliding_or_weighing(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "visual.usda")
    body(stage, "/World/part", size=0.1)
    shell = UsdGeom.Sphere.Define(stage, "/World/part/shell")
    shell.CreateRadiusAttr(0.5)
    shell.CreateDisplayColorAttr([(0.8, 0.1, 0.2)])
    UsdGeom.Cube.Define(stage, "/World/part/hidden").CreateVisibilityAttr(UsdGeom.Tokens.invisible)
    decal = UsdGeom.Mesh.Define(stage, "/World/part/decal")  # flat and open: no volume
    decal.CreatePointsAttr([(0, 0, 0.06), (0.1, 0, 0.06), (0.1, 0.1, 0.06), (0, 0.1, 0.06)])
    decal.CreateFaceVertexCountsAttr([4])
    decal.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    collider(stage, UsdGeom.Plane, "/World/ground", axis="Y")
    floor = UsdGeom.Mesh.Define(stage, "/World/floor")  # a flat collider: a thin box in MuJoCo
    floor.CreatePointsAttr([(-2, -1, -0.5), (2, -1, -0.5), (2, 1, -0.5), (-2, 1, -0.5)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    UsdPhysics.CollisionAPI.Apply(floor.GetPrim())
    stage.Save()
    model, data, warnings = forward(tmp_path / "visual.usda")
    assert model.geom("floor").type == GEOM.mjGEOM_BOX
    np.testing.assert_allclose(np.sort(model.geom("floor").size), [5e-4, 1, 2])
    np.testing.assert_allclose(data.geom("floor").xpos, [0, 0, -0.5], atol=1e-12)
    assert any(w.startswith("/World/floor: a flat collider mesh") for w in warnings)
    assert model.geom("decal").type == GEOM.mjGEOM_MESH and model.geom("decal").contype[0] == 0
    ground = model.geom("ground")
    assert ground.type == GEOM.mjGEOM_PLANE and ground.bodyid[0] == 0 and ground.contype[0] == 1
    np.testing.assert_allclose(ground.quat, [math.cos(math.pi / 4), -math.sin(math.pi / 4), 0, 0])  # normal +Y
    shell_geom = model.geom("shell")
    assert (shell_geom.contype[0], shell_geom.conaffinity[0], shell_geom.group[0]) == (0, 0, 2)
    np.testing.assert_allclose(shell_geom.rgba, [0.8, 0.1, 0.2, 1.0], atol=1e-6)
    assert model.body("part").mass[0] == pytest.approx(1.0)  # the 10 cm cube's 1 kg, nothing from the shell
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "hidden") == -1


def wheel_layer(path: Path) -> None:
    """A layer with /Wheel: a cylinder collider of radius 0.2 m."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, "Z")
    wheel = UsdGeom.Xform.Define(stage, "/Wheel")
    stage.SetDefaultPrim(wheel.GetPrim())
    collider(stage, UsdGeom.Cylinder, "/Wheel/tyre", radius=0.2, height=0.1, axis="Y")
    stage.Save()


def test_colliders_through_references_payloads_instances_sublayers_and_variants(tmp_path: Path) -> None:
    wheel_layer(tmp_path / "wheel.usda")
    extra = Usd.Stage.CreateNew(str(tmp_path / "extra.usda"))
    body(extra, "/World/crate", (0, 0, 2), size=0.5)
    extra.Save()
    stage = new_stage(tmp_path / "car.usda")
    stage.GetRootLayer().subLayerPaths.append("extra.usda")
    body(stage, "/World/car", (0, 0, 1), size=0.4)
    for index, (x, how) in enumerate(((1, "reference"), (2, "payload"), (3, "instance"), (4, "instance"))):
        hub = body(stage, f"/World/hub{index}", (x, 0, 1), size=0.05)
        wheel = stage.DefinePrim(f"/World/hub{index}/wheel")
        if how == "payload":
            wheel.GetPayloads().AddPayload(str(tmp_path / "wheel.usda"))
        else:
            wheel.GetReferences().AddReference(str(tmp_path / "wheel.usda"))
        wheel.SetInstanceable(how == "instance")
        assert wheel.IsInstance() == (how == "instance") and hub.IsValid()
    stage.GetPrimAtPath("/World/car/box").GetAttribute("size").Clear()  # only the variants author it
    variants = stage.GetPrimAtPath("/World/car").GetVariantSets().AddVariantSet("size")
    for name, size in (("small", 0.4), ("large", 1.0)):
        variants.AddVariant(name)
        variants.SetVariantSelection(name)
        with variants.GetVariantEditContext():
            stage.GetPrimAtPath("/World/car/box").GetAttribute("size").Set(size)
    stage.Save()
    model, data, _ = forward(tmp_path / "car.usda")
    tyres = [name for name in (model.geom(i).name for i in range(model.ngeom)) if name.endswith("tyre")]
    assert sorted(tyres) == [f"hub{i}/wheel/tyre" for i in range(4)]
    for index in range(4):
        geom = data.geom(f"hub{index}/wheel/tyre")
        np.testing.assert_allclose(geom.xpos, [index + 1, 0, 1])
        np.testing.assert_allclose(geom.xmat.reshape(3, 3)[:, 2], [0, 1, 0], atol=1e-9)
        assert model.geom(f"hub{index}/wheel/tyre").size[0] == pytest.approx(0.2)
    assert model.geom("crate/box").size[0] == pytest.approx(0.25)
    assert model.geom("car/box").size[0] == pytest.approx(0.5)  # the selected "large" variant
