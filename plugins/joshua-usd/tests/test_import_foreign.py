"""Stages laid out the way NVIDIA's tools write them, built with pxr from the UsdPhysics schema: an atomic component
(interface layer -> payload -> contents sublayering physics, materials and geometry layers, meshes and materials
referenced from library layers, rigid bodies nested in their parents, the robot welded to its root Xform) as
mujoco-usd-converter writes it, and an Isaac-Sim-importer robot (sibling links, joints in a scope, a root joint with
no body0, drives, colliders on instanceable Xforms whose meshes live in a referenced layer). Each must load with
the right joints, limits, drives, colliders and masses; `joshua usd inspect`'s report of each is printed."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
from pxr import Gf, Kind, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade

from joshua_usd.importer import import_usd
from joshua_usd.inspect import describe

CUBE_POINTS = [(x, y, z) for x in (-0.05, 0.05) for y in (-0.05, 0.05) for z in (-0.05, 0.05)]
KP, KV, MAX_TORQUE = 0.05, 0.003, 0.02  # the converter stage's shoulder servo (N m/rad, N m s/rad, N m)
CUBE_FACES = [0, 1, 3, 2, 4, 6, 7, 5, 0, 4, 5, 1, 2, 3, 7, 6, 0, 2, 6, 4, 1, 5, 7, 3]


def layer_stage(path: Path, root: str) -> Usd.Stage:
    """A new layer, Z up in metres and kilograms, whose default prim is `root` (an over unless defined later)."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    stage.SetDefaultPrim(stage.OverridePrim(root))
    return stage


def cube_mesh(stage: Usd.Stage, path: str) -> UsdGeom.Mesh:
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(CUBE_POINTS)
    mesh.CreateFaceVertexCountsAttr([4] * 6)
    mesh.CreateFaceVertexIndicesAttr(CUBE_FACES)
    return mesh


def uniform(prim: Usd.Prim, name: str, kind: Sdf.ValueTypeName, value: object) -> None:
    """A schema attribute of mjcPhysics (not registered with usd-core, so written as the converter's are)."""
    prim.CreateAttribute(name, kind, custom=False, variability=Sdf.VariabilityUniform).Set(value)


def mjc_actuator(stage: Usd.Stage, path: str, target: str) -> Usd.Prim:
    """An MjcActuator prim (MuJoCo's USD schema) whose transmission is the joint or body at `target`."""
    prim = stage.DefinePrim(path, "MjcActuator")
    prim.CreateRelationship("mjc:target", custom=False).SetTargets([target])
    return prim


def converter_asset(folder: Path) -> Path:
    """arm.usda -> Payload/Contents.usda (sublayers Physics, Materials, Geometry); GeometryLibrary.usdc and
    MaterialsLibrary.usdc hold the mesh and the material. /arm is moved 1 m along x and turned 90 deg about z.
    The shoulder is driven by an MjcActuator in /arm/Physics: a position servo (kp, kv, clamped ctrl and force)."""
    payload = folder / "Payload"
    payload.mkdir(parents=True)
    library = layer_stage(payload / "GeometryLibrary.usdc", "/Geometry")
    UsdGeom.Scope.Define(library, "/Geometry")
    cube_mesh(library, "/Geometry/box")
    library.Save()
    materials_library = layer_stage(payload / "MaterialsLibrary.usdc", "/Materials")
    UsdGeom.Scope.Define(materials_library, "/Materials")
    UsdShade.Material.Define(materials_library, "/Materials/red")
    materials_library.Save()

    geometry = layer_stage(payload / "Geometry.usda", "/arm")
    UsdGeom.Scope.Define(geometry, "/arm/Geometry")
    base = UsdGeom.Xform.Define(geometry, "/arm/Geometry/base")
    base.AddTranslateOp().Set(Gf.Vec3d(0, 0, 0.05))
    mesh = geometry.DefinePrim("/arm/Geometry/base/base_geom", "Mesh")
    mesh.GetReferences().AddReference("./GeometryLibrary.usdc", "/Geometry/box")
    link = UsdGeom.Xform.Define(geometry, "/arm/Geometry/base/link")  # nested in its parent body
    link.AddTranslateOp().Set(Gf.Vec3d(0, 0, 0.1))
    capsule = UsdGeom.Capsule.Define(geometry, "/arm/Geometry/base/link/link_geom")
    capsule.CreateRadiusAttr(0.02)
    capsule.CreateHeightAttr(0.1)
    capsule.CreateAxisAttr("Z")
    UsdGeom.Xformable(capsule).AddTranslateOp().Set(Gf.Vec3d(0, 0, 0.05))
    hinge = UsdPhysics.RevoluteJoint.Define(geometry, "/arm/Geometry/base/link/shoulder")
    hinge.CreateBody0Rel().SetTargets(["/arm/Geometry/base"])
    hinge.CreateBody1Rel().SetTargets(["/arm/Geometry/base/link"])
    hinge.CreateAxisAttr("Z")
    hinge.CreateLocalPos0Attr(Gf.Vec3f(0, 0, 0.1))
    hinge.CreateLocalPos1Attr(Gf.Vec3f(0, 0, 0))
    hinge.CreateLowerLimitAttr(-110.0)
    hinge.CreateUpperLimitAttr(110.0)
    anchor = UsdPhysics.FixedJoint.Define(geometry, "/arm/Geometry/base/FixedJoint")
    anchor.CreateBody0Rel().SetTargets(["/arm"])  # the default prim: an Xform, no rigid body
    anchor.CreateBody1Rel().SetTargets(["/arm/Geometry/base"])
    anchor.CreateLocalPos0Attr(Gf.Vec3f(0, 0, 0.05))
    anchor.CreateLocalPos1Attr(Gf.Vec3f(0, 0, 0))
    geometry.Save()

    materials = layer_stage(payload / "Materials.usda", "/arm")
    UsdGeom.Scope.Define(materials, "/arm/Materials")
    red = materials.DefinePrim("/arm/Materials/red", "Material")
    red.GetReferences().AddReference("./MaterialsLibrary.usdc", "/Materials/red")
    bound = materials.OverridePrim("/arm/Geometry/base/base_geom")
    UsdShade.MaterialBindingAPI.Apply(bound).Bind(UsdShade.Material(red))
    materials.Save()

    physics = layer_stage(payload / "Physics.usda", "/arm")
    for path, mass in (("/arm/Geometry/base", 0.5), ("/arm/Geometry/base/link", 0.2)):
        prim = physics.OverridePrim(path)
        UsdPhysics.RigidBodyAPI.Apply(prim)
        UsdPhysics.MassAPI.Apply(prim).CreateMassAttr(mass)
    UsdPhysics.ArticulationRootAPI.Apply(physics.OverridePrim("/arm/Geometry/base"))
    UsdPhysics.CollisionAPI.Apply(physics.OverridePrim("/arm/Geometry/base/link/link_geom"))
    mesh_collider = physics.OverridePrim("/arm/Geometry/base/base_geom")
    UsdPhysics.CollisionAPI.Apply(mesh_collider)
    UsdPhysics.MeshCollisionAPI.Apply(mesh_collider).CreateApproximationAttr("convexHull")
    scene = UsdPhysics.Scene.Define(physics, "/arm/Physics/PhysicsScene").GetPrim()
    scene.AddAppliedSchema("MjcSceneAPI")
    uniform(scene, "mjc:compiler:angle", Sdf.ValueTypeNames.Token, "degree")
    shoulder = mjc_actuator(physics, "/arm/Physics/shoulder", "/arm/Geometry/base/link/shoulder")
    for name, kind, value in (
        ("mjc:gainType", Sdf.ValueTypeNames.Token, "fixed"),
        ("mjc:biasType", Sdf.ValueTypeNames.Token, "affine"),
        ("mjc:gainPrm", Sdf.ValueTypeNames.DoubleArray, [KP, 0, 0, 0, 0, 0, 0, 0, 0, 0]),
        ("mjc:biasPrm", Sdf.ValueTypeNames.DoubleArray, [0, -KP, -KV, 0, 0, 0, 0, 0, 0, 0]),
        ("mjc:gear", Sdf.ValueTypeNames.DoubleArray, [1, 0, 0, 0, 0, 0]),
        ("mjc:ctrlLimited", Sdf.ValueTypeNames.Token, "true"),
        ("mjc:ctrlRange:min", Sdf.ValueTypeNames.Double, -1.9),
        ("mjc:ctrlRange:max", Sdf.ValueTypeNames.Double, 1.9),
        ("mjc:forceLimited", Sdf.ValueTypeNames.Token, "auto"),
        ("mjc:forceRange:min", Sdf.ValueTypeNames.Double, -MAX_TORQUE),
        ("mjc:forceRange:max", Sdf.ValueTypeNames.Double, MAX_TORQUE),
    ):
        uniform(shoulder, name, kind, value)
    physics.Save()

    contents = layer_stage(payload / "Contents.usda", "/arm")
    contents.GetRootLayer().subLayerPaths = ["./Physics.usda", "./Materials.usda", "./Geometry.usda"]
    contents.DefinePrim("/arm", "Xform")
    contents.Save()

    interface = layer_stage(folder / "arm.usda", "/arm")
    arm = UsdGeom.Xform.Define(interface, "/arm")
    arm.AddTranslateOp().Set(Gf.Vec3d(1, 0, 0))
    arm.AddRotateZOp().Set(90.0)
    Usd.ModelAPI(arm.GetPrim()).SetKind(Kind.Tokens.component)
    arm.GetPrim().GetPayloads().AddPayload("./Payload/Contents.usda")
    interface.Save()
    return folder / "arm.usda"


def isaac_robot(folder: Path) -> Path:
    """robot.usda: /robot (ArticulationRootAPI) with sibling links base and finger, joints in /robot/joints (a
    root_joint with only body1, a prismatic joint with a position drive), each link's colliders an instanceable
    Xform referencing Props/instanceable_meshes.usda."""
    (folder / "Props").mkdir(parents=True)
    meshes = layer_stage(folder / "Props" / "instanceable_meshes.usda", "/base")
    for link in ("base", "finger"):
        UsdGeom.Xform.Define(meshes, f"/{link}")
        UsdGeom.Xform.Define(meshes, f"/{link}/collisions")
        collider = cube_mesh(meshes, f"/{link}/collisions/mesh_0").GetPrim()
        UsdPhysics.CollisionAPI.Apply(collider)
        UsdPhysics.MeshCollisionAPI.Apply(collider).CreateApproximationAttr("convexHull")
        collider.AddAppliedSchema("PhysxConvexHullCollisionAPI")
    meshes.Save()

    stage = layer_stage(folder / "robot.usda", "/robot")
    robot = UsdGeom.Xform.Define(stage, "/robot").GetPrim()
    UsdPhysics.ArticulationRootAPI.Apply(robot)
    robot.AddAppliedSchema("PhysxArticulationAPI")
    robot.CreateAttribute("physxArticulation:enabledSelfCollisions", Sdf.ValueTypeNames.Bool).Set(False)
    UsdPhysics.Scene.Define(stage, "/physicsScene")
    for link, z, mass in (("base", 0.05, 2.0), ("finger", 0.2, 0.1)):
        xform = UsdGeom.Xform.Define(stage, f"/robot/{link}")
        xform.AddTranslateOp().Set(Gf.Vec3d(0, 0, z))
        xform.AddOrientOp().Set(Gf.Quatf(1, 0, 0, 0))
        UsdPhysics.RigidBodyAPI.Apply(xform.GetPrim())
        mass_api = UsdPhysics.MassAPI.Apply(xform.GetPrim())
        mass_api.CreateMassAttr(mass)
        mass_api.CreateCenterOfMassAttr(Gf.Vec3f(0, 0, 0.01))
        mass_api.CreateDiagonalInertiaAttr(Gf.Vec3f(1e-3, 1e-3, 2e-3))
        collisions = stage.DefinePrim(f"/robot/{link}/collisions", "Xform")
        collisions.GetReferences().AddReference("./Props/instanceable_meshes.usda", f"/{link}/collisions")
        collisions.SetInstanceable(True)
    UsdGeom.Scope.Define(stage, "/robot/joints")
    root = UsdPhysics.FixedJoint.Define(stage, "/robot/joints/root_joint")
    root.CreateBody1Rel().SetTargets(["/robot/base"])
    root.CreateLocalPos0Attr(Gf.Vec3f(0, 0, 0.05))
    root.CreateLocalPos1Attr(Gf.Vec3f(0, 0, 0))
    slider = UsdPhysics.PrismaticJoint.Define(stage, "/robot/joints/finger_joint")
    slider.CreateBody0Rel().SetTargets(["/robot/base"])
    slider.CreateBody1Rel().SetTargets(["/robot/finger"])
    slider.CreateAxisAttr("Z")
    slider.CreateLocalPos0Attr(Gf.Vec3f(0, 0, 0.15))
    slider.CreateLocalPos1Attr(Gf.Vec3f(0, 0, 0))
    slider.CreateLowerLimitAttr(-0.01)
    slider.CreateUpperLimitAttr(0.04)
    drive = UsdPhysics.DriveAPI.Apply(slider.GetPrim(), "linear")
    drive.CreateTypeAttr("force")
    drive.CreateStiffnessAttr(500.0)
    drive.CreateDampingAttr(20.0)
    drive.CreateMaxForceAttr(40.0)
    drive.CreateTargetPositionAttr(0.0)
    stage.Save()
    return folder / "robot.usda"


def test_mujoco_usd_converter_layout_loads(tmp_path: Path) -> None:
    path = converter_asset(tmp_path / "arm")
    print(describe(path))
    imported = import_usd(path)
    model = imported.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert [model.body(i).name for i in range(model.nbody)] == ["world", "base", "link"]
    assert model.body("base").parentid[0] == 0 and model.body("base").jntnum[0] == 0  # welded to the world
    assert model.njnt == 1 and model.jnt_type[0] == mujoco.mjtJoint.mjJNT_HINGE
    np.testing.assert_allclose(model.jnt_range[0], np.radians([-110.0, 110.0]), atol=1e-6)
    np.testing.assert_allclose(data.body("base").xpos, [1, 0, 0.05], atol=1e-6)
    np.testing.assert_allclose(data.body("link").xpos, [1, 0, 0.15], atol=1e-6)
    np.testing.assert_allclose(data.body("base").xquat, [math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4)], atol=1e-6)
    np.testing.assert_allclose(data.joint("shoulder").xaxis, [0, 0, 1], atol=1e-6)
    np.testing.assert_allclose([model.body("base").mass[0], model.body("link").mass[0]], [0.5, 0.2], rtol=1e-6)
    colliders = {model.geom(i).name: model.geom_type[i] for i in range(model.ngeom) if model.geom_contype[i]}
    assert colliders == {"base_geom": mujoco.mjtGeom.mjGEOM_MESH, "link_geom": mujoco.mjtGeom.mjGEOM_CAPSULE}
    assert model.geom("base_geom").bodyid[0] == model.body("base").id
    assert model.geom("link_geom").bodyid[0] == model.body("link").id
    np.testing.assert_allclose(model.geom_rbound[model.geom("base_geom").id], math.sqrt(3) * 0.05, rtol=1e-6)
    assert not imported.report.warnings
    assert model.nu == 1 and model.actuator_trnid[0, 0] == model.joint("shoulder").id
    actuator = model.actuator("shoulder")
    np.testing.assert_allclose(actuator.gainprm[:3], [KP, 0, 0])
    np.testing.assert_allclose(actuator.biasprm[:3], [0, -KP, -KV])
    np.testing.assert_allclose(actuator.ctrlrange, [-1.9, 1.9])
    np.testing.assert_allclose(actuator.forcerange, [-MAX_TORQUE, MAX_TORQUE])
    assert actuator.ctrllimited[0] and actuator.forcelimited[0]  # "auto" with a range: limited (autolimits)


def test_mujoco_usd_converter_actuator_drives_its_joint(tmp_path: Path) -> None:
    """The converter's MjcActuator turns the shoulder to the commanded angle, with the torque clamped."""
    model = import_usd(converter_asset(tmp_path / "arm")).spec.compile()
    data = mujoco.MjData(model)
    data.ctrl[0] = 0.8  # rad
    torques = []
    for _ in range(int(2.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
        torques.append(data.actuator_force[0])
    assert data.joint("shoulder").qpos[0] == pytest.approx(0.8, abs=0.01)
    assert max(np.abs(torques)) == pytest.approx(MAX_TORQUE, rel=1e-9)  # kp x 0.8 = 0.04 N m, clamped


def test_unsupported_mjc_actuators_are_warned_and_left_out(tmp_path: Path) -> None:
    path = converter_asset(tmp_path / "arm")
    physics = Usd.Stage.Open(str(path.parent / "Payload" / "Physics.usda"))
    user = mjc_actuator(physics, "/arm/Physics/user_kind", "/arm/Geometry/base/link/shoulder")
    uniform(user, "mjc:gainType", Sdf.ValueTypeNames.Token, "user")
    mjc_actuator(physics, "/arm/Physics/on_site", "/arm/Geometry/base/link/link_geom")
    crank = mjc_actuator(physics, "/arm/Physics/crank", "/arm/Geometry/base/link/shoulder")
    crank.CreateRelationship("mjc:sliderSite", custom=False).SetTargets(["/arm/Geometry/base"])
    physics.Save()
    imported = import_usd(path)
    model = imported.spec.compile()
    assert [model.actuator(i).name for i in range(model.nu)] == ["shoulder"]
    assert imported.report.warnings == [
        "/arm/Physics/user_kind: MjcActuator with mjc:gainType user is not supported: not imported",
        "/arm/Physics/on_site: MjcActuator target </arm/Geometry/base/link/link_geom> is not an imported joint or "
        "rigid body: not imported",
        "/arm/Physics/crank: MjcActuator with mjc:sliderSite is not supported: not imported",
    ]


def test_isaac_importer_layout_with_instanceable_colliders_loads(tmp_path: Path) -> None:
    path = isaac_robot(tmp_path / "robot")
    assert Usd.Stage.Open(str(path)).GetPrimAtPath("/robot/finger/collisions").IsInstance()
    print(describe(path))
    imported = import_usd(path)
    model = imported.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert model.body("base").jntnum[0] == 0 and model.body("base").parentid[0] == 0
    assert model.njnt == 1 and model.jnt_type[0] == mujoco.mjtJoint.mjJNT_SLIDE
    np.testing.assert_allclose(model.jnt_range[0], [-0.01, 0.04], atol=1e-9)
    np.testing.assert_allclose(data.body("finger").xpos, [0, 0, 0.2], atol=1e-6)
    actuator = model.actuator("finger_joint")
    assert actuator.gainprm[0] == pytest.approx(500.0) and -actuator.biasprm[2] == pytest.approx(20.0)
    np.testing.assert_allclose(actuator.forcerange, [-40.0, 40.0])
    for name, mass in (("base", 2.0), ("finger", 0.1)):
        body = model.body(name)
        assert body.mass[0] == pytest.approx(mass)
        np.testing.assert_allclose(body.ipos, [0, 0, 0.01], atol=1e-7)
        np.testing.assert_allclose(sorted(body.inertia), [1e-3, 1e-3, 2e-3], rtol=1e-6)
        geoms = [i for i in range(model.ngeom) if model.geom_bodyid[i] == body.id and model.geom_contype[i]]
        assert len(geoms) == 1 and model.geom_type[geoms[0]] == mujoco.mjtGeom.mjGEOM_MESH
    assert model.nexclude == 1  # enabledSelfCollisions false
    assert not imported.report.warnings
