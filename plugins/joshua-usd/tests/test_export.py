"""MuJoCo -> USD export: the written stages, read back with pxr, against the compiled MuJoCo models."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdPhysics, UsdShade, UsdValidation

from joshua_core.resources import models_dir
from joshua_usd.exporter import export_model

MODELS = {"so100": "so_arm100/so_arm100.xml", "ant": "ant/ant.xml", "trileg": "trileg/trileg.xml"}
AXIS = {"X": Gf.Vec3d(1, 0, 0), "Y": Gf.Vec3d(0, 1, 0), "Z": Gf.Vec3d(0, 0, 1)}

# Every joint kind, an oblique hinge axis, a ref, a rotated body, a jointless child and a world camera.
ODD_MODEL = """
<mujoco model="odd robot">
  <worldbody>
    <camera name="overview" pos="0 -2 1" xyaxes="1 0 0 0 0.5 1" fovy="60"/>
    <body name="carriage" pos="0.1 0.2 0.3" quat="0.9 0.1 -0.3 0.2">
      <joint name="rail" type="slide" axis="0 -1 0.2" range="-0.1 0.2" ref="0.05"/>
      <geom type="box" size="0.05 0.04 0.03" mass="1"/>
      <body name="arm" pos="0.2 0 0" euler="0.3 0.2 0.1">
        <joint name="hinge" axis="0.3 -0.5 0.8" pos="0.01 0.02 0.03" range="-1 1.5" ref="0.4"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.5"/>
        <body name="bracket" pos="0.2 0 0" euler="0 0.5 0">
          <geom type="sphere" size="0.03" mass="0.1"/>
          <body name="ball link" pos="0.05 0 0">
            <joint name="ball" type="ball" range="0 0.7"/>
            <geom type="cylinder" size="0.02 0.05" mass="0.2" rgba="1 0 0 0.5"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="rail_servo" joint="rail" kp="200" kv="5" gear="2" forcerange="-30 30"/>
    <motor name="hinge_motor" joint="hinge" gear="3" ctrlrange="-2 2"/>
  </actuator>
</mujoco>
"""


def _load(xml: Path, out: Path) -> tuple[mujoco.MjModel, mujoco.MjData, Usd.Stage]:
    model = mujoco.MjModel.from_xml_path(str(xml))
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    return model, data, Usd.Stage.Open(str(export_model(xml, out)))


@pytest.fixture(scope="module", params=[*MODELS, "odd"])
def exported(request, tmp_path_factory) -> tuple[mujoco.MjModel, mujoco.MjData, Usd.Stage]:
    folder = tmp_path_factory.mktemp(request.param)
    if request.param == "odd":
        xml = folder / "odd.xml"
        xml.write_text(ODD_MODEL)
    else:
        xml = models_dir() / MODELS[request.param]
    return _load(xml, folder / f"{request.param}.usd")


def _prims(stage: Usd.Stage, schema: type) -> list[Usd.Prim]:
    return [prim for prim in stage.Traverse() if prim.IsA(schema) or prim.HasAPI(schema)]


def _world(prim: Usd.Prim) -> Gf.Matrix4d:
    """The prim's local-to-world matrix; for Isaac's sensor types (no schema in usd-core, so USD does not
    compute theirs) its xformOps after its parent's."""
    if prim.IsA(UsdGeom.Xformable):
        return UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
    local = Gf.Matrix4d(1)
    for name in prim.GetAttribute("xformOpOrder").Get():
        local = UsdGeom.XformOp(prim.GetAttribute(name)).GetOpTransform(Usd.TimeCode.Default()) * local
    return local * _world(prim.GetParent())


def _rotation(matrix: Gf.Matrix4d) -> Gf.Rotation:
    return Gf.Rotation(matrix.ExtractRotationQuat())


def _joint_frames(stage: Usd.Stage, joint: UsdPhysics.Joint) -> list[tuple[np.ndarray, Gf.Rotation]]:
    """Both sides of a joint in the world: (anchor, frame rotation) from body0 and from body1."""
    frames = []
    for side in (0, 1):
        targets = getattr(joint, f"GetBody{side}Rel")().GetTargets()
        body = _world(stage.GetPrimAtPath(targets[0])) if targets else Gf.Matrix4d(1)
        anchor = body.Transform(Gf.Vec3d(getattr(joint, f"GetLocalPos{side}Attr")().Get()))
        local = Gf.Rotation(Gf.Quatd(getattr(joint, f"GetLocalRot{side}Attr")().Get()))
        frames.append((np.array(anchor), local * _rotation(body)))
    return frames


def test_stage_has_units_scene_and_one_articulation(exported) -> None:
    model, _, stage = exported
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1 and UsdPhysics.GetStageKilogramsPerUnit(stage) == 1
    root = stage.GetDefaultPrim()
    assert root.HasAPI(UsdPhysics.ArticulationRootAPI)
    (scene,) = _prims(stage, UsdPhysics.Scene)
    assert scene.GetAttribute("physxScene:timeStepsPerSecond").Get() == round(1 / model.opt.timestep)
    assert UsdPhysics.Scene(scene).GetGravityMagnitudeAttr().Get() == pytest.approx(9.81)
    parsed = UsdPhysics.UsdPhysicsLoadStageFromPrimRange(stage, ["/"])  # the reference UsdPhysics parser
    (articulation,) = parsed[UsdPhysics.ObjectType.Articulation][1]
    assert len([path for path in articulation.articulatedBodies if not path.isEmpty]) == model.nbody - 1
    assert len(parsed[UsdPhysics.ObjectType.RigidBody][0]) == model.nbody - 1


def test_openusd_validators_find_nothing(exported) -> None:
    """All of OpenUSD's validators: stage metadata, UsdPhysics articulations, colliders, joints, rigid
    bodies, material bindings, attribute types."""
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    errors = UsdValidation.ValidationContext(validators).Validate(exported[2])
    assert not [error.GetMessage() for error in errors]


def test_bodies_have_mujoco_mass_inertia_and_world_pose(exported) -> None:
    model, data, stage = exported
    bodies = _prims(stage, UsdPhysics.RigidBodyAPI)
    assert [prim.GetName() for prim in bodies] == [model.body(i).name.replace(" ", "_") for i in range(1, model.nbody)]
    assert all(prim.GetParent() == stage.GetDefaultPrim() for prim in bodies)
    for body, prim in enumerate(bodies, start=1):
        mass = UsdPhysics.MassAPI(prim)
        assert mass.GetMassAttr().Get() == pytest.approx(model.body_mass[body], rel=1e-6)
        np.testing.assert_allclose(mass.GetDiagonalInertiaAttr().Get(), model.body_inertia[body], rtol=1e-6)
        np.testing.assert_allclose(mass.GetCenterOfMassAttr().Get(), model.body_ipos[body], atol=1e-7)
        axes = mass.GetPrincipalAxesAttr().Get()
        assert abs(np.dot([axes.GetReal(), *axes.GetImaginary()], model.body_iquat[body])) == pytest.approx(1, abs=1e-6)
        world = _world(prim)
        np.testing.assert_allclose(world.ExtractTranslation(), data.xpos[body], atol=1e-12)
        np.testing.assert_allclose(np.array(world.ExtractRotationMatrix()).T, data.xmat[body].reshape(3, 3), atol=1e-9)


def test_both_sides_of_every_joint_meet_at_mujocos_anchor_and_axis(exported) -> None:
    model, data, stage = exported
    joints = {prim.GetName(): UsdPhysics.Joint(prim) for prim in _prims(stage, UsdPhysics.Joint)}
    movable = [j for j in range(model.njnt) if model.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE]
    fixed = [b for b in range(1, model.nbody) if model.body_jntnum[b] == 0]
    assert len(joints) == len(movable) + len(fixed)
    for j in movable:
        joint = joints[model.joint(j).name]
        (anchor0, rot0), (anchor1, rot1) = _joint_frames(stage, joint)
        np.testing.assert_allclose(anchor0, data.xanchor[j], atol=1e-6)
        np.testing.assert_allclose(anchor1, data.xanchor[j], atol=1e-6)
        assert abs(Gf.Dot(rot0.GetQuat(), rot1.GetQuat())) == pytest.approx(1, abs=1e-12)
        if model.jnt_type[j] != mujoco.mjtJoint.mjJNT_BALL:
            axis = rot0.TransformDir(AXIS[joint.GetPrim().GetAttribute("physics:axis").Get()])
            np.testing.assert_allclose(axis, data.xaxis[j], atol=1e-6)
        body1 = model.body(model.jnt_bodyid[j]).name.replace(" ", "_")
        expected_body1 = stage.GetDefaultPrim().GetPath().AppendChild(body1)
        assert joint.GetBody1Rel().GetTargets() == [expected_body1]
    for body in fixed:
        joint = joints[f"{model.body(body).name.replace(' ', '_')}_fixed"]
        assert bool(joint.GetBody0Rel().GetTargets()) == bool(model.body_parentid[body])
        (anchor0, _), (anchor1, _) = _joint_frames(stage, joint)
        np.testing.assert_allclose(anchor0, anchor1, atol=1e-6)


def test_limits_are_in_degrees_relative_to_the_reference_pose(exported) -> None:
    model, _, stage = exported
    for j in range(model.njnt):
        prim = stage.GetPrimAtPath(stage.GetDefaultPrim().GetPath().AppendPath(f"joints/{model.joint(j).name}"))
        kind = model.jnt_type[j]
        if kind == mujoco.mjtJoint.mjJNT_FREE:
            assert not prim
            continue
        if kind == mujoco.mjtJoint.mjJNT_BALL:
            cone = prim.GetAttribute("physics:coneAngle0Limit").Get()
            assert cone == pytest.approx(np.degrees(model.jnt_range[j, 1]))
            continue
        ref = model.qpos0[model.jnt_qposadr[j]]
        expected = model.jnt_range[j] - ref
        if kind == mujoco.mjtJoint.mjJNT_HINGE:
            assert prim.IsA(UsdPhysics.RevoluteJoint)
            expected = np.degrees(expected)
        else:
            assert prim.IsA(UsdPhysics.PrismaticJoint)
        limits = [prim.GetAttribute(f"physics:{side}Limit").Get() for side in ("lower", "upper")]
        np.testing.assert_allclose(limits, expected, rtol=1e-6)
        axis = "angular" if kind == mujoco.mjtJoint.mjJNT_HINGE else "linear"
        armature = prim.GetAttribute(f"physxJointAxis:{axis}:armature").Get()
        assert armature == pytest.approx(model.dof_armature[model.jnt_dofadr[j]])


def test_drives_carry_the_actuators_in_per_degree_units(exported) -> None:
    model, _, stage = exported
    root = stage.GetDefaultPrim().GetPath()
    for actuator in range(model.nu):
        joint = model.actuator_trnid[actuator, 0]
        prim = stage.GetPrimAtPath(root.AppendPath(f"joints/{model.joint(joint).name}"))
        angular = model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_HINGE
        drive = UsdPhysics.DriveAPI(prim, "angular" if angular else "linear")
        unit = math.pi / 180 if angular else 1.0
        gear = model.actuator_gear[actuator, 0]
        motor = model.actuator_biastype[actuator] == mujoco.mjtBias.mjBIAS_NONE
        assert prim.GetAttribute("joshua:actuator:kind").Get() == ("motor" if motor else "position")
        kp = 0.0 if motor else model.actuator_gainprm[actuator, 0]
        kv = 0.0 if motor else -model.actuator_biasprm[actuator, 2]
        assert drive.GetStiffnessAttr().Get() == pytest.approx(gear**2 * kp * unit)
        assert drive.GetDampingAttr().Get() == pytest.approx(gear**2 * kv * unit)
        limit = np.abs(model.actuator_ctrlrange[actuator] if motor else model.actuator_forcerange[actuator]).max()
        assert drive.GetMaxForceAttr().Get() == pytest.approx(limit * gear)
        axis = "angular" if angular else "linear"
        damping = prim.GetAttribute(f"physxJointAxis:{axis}:viscousFrictionCoefficient").Get()
        assert damping == pytest.approx(model.dof_damping[model.jnt_dofadr[joint]] * unit)


def test_colliders_have_shapes_sizes_and_friction(exported) -> None:
    model, data, stage = exported
    colliders = _prims(stage, UsdPhysics.CollisionAPI)
    expected = [g for g in range(model.ngeom) if model.geom_contype[g] or model.geom_conaffinity[g]]
    expected.sort(key=lambda g: model.geom_bodyid[g] == 0)  # world geoms are in /Environment, after the robot
    assert len(colliders) == len(expected)
    for geom, prim in zip(expected, colliders, strict=True):
        size = model.geom_size[geom]
        kind = mujoco.mjtGeom(model.geom_type[geom])
        if kind == mujoco.mjtGeom.mjGEOM_BOX:
            assert prim.GetAttribute("size").Get() == 2
            np.testing.assert_allclose(prim.GetAttribute("xformOp:scale").Get(), size, rtol=1e-12)
        elif kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
            shape = prim.GetAttribute("radius").Get(), prim.GetAttribute("height").Get()
            assert shape == pytest.approx((size[0], 2 * size[1]))
        elif kind == mujoco.mjtGeom.mjGEOM_PLANE:
            assert prim.IsA(UsdGeom.Plane) and str(prim.GetPath()).startswith("/Environment/")
        rest = prim.GetAttribute("physxCollision:restOffset").Get()
        margin = model.geom_margin[geom]
        assert rest == (pytest.approx(margin - model.geom_gap[geom]) if margin else None)
        material = UsdShade.MaterialBindingAPI(prim).GetDirectBinding("physics").GetMaterial()
        friction = UsdPhysics.MaterialAPI(material.GetPrim())
        assert friction.GetDynamicFrictionAttr().Get() == pytest.approx(model.geom_friction[geom, 0])
        np.testing.assert_allclose(_world(prim).ExtractTranslation(), data.geom_xpos[geom], atol=1e-9)


def test_so100_visual_meshes_and_looks(tmp_path: Path) -> None:
    model, _, stage = _load(models_dir() / MODELS["so100"], tmp_path / "so100.usda")
    meshes = [prim for prim in stage.Traverse() if prim.IsA(UsdGeom.Mesh)]
    geoms = [g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH]
    assert len(meshes) == len(geoms) and not any(prim.HasAPI(UsdPhysics.CollisionAPI) for prim in meshes)
    for geom, prim in zip(geoms, meshes, strict=True):
        mesh_id = model.geom_dataid[geom]
        points = np.array(UsdGeom.Mesh(prim).GetPointsAttr().Get())
        np.testing.assert_allclose(points, model.mesh_vert[model.mesh_vertadr[mesh_id] :][: len(points)], atol=1e-7)
        assert len(points) == model.mesh_vertnum[mesh_id]
        assert len(UsdGeom.Mesh(prim).GetFaceVertexIndicesAttr().Get()) == 3 * model.mesh_facenum[mesh_id]
        look = UsdShade.MaterialBindingAPI(prim).GetDirectBinding().GetMaterial()
        shader = UsdShade.Shader(look.GetPrim().GetChild("PreviewSurface"))
        matid = model.geom_matid[geom]
        assert look.GetPrim().GetName() == model.material(matid).name
        np.testing.assert_allclose(shader.GetInput("diffuseColor").Get(), model.mat_rgba[matid, :3], rtol=1e-6)
        assert shader.GetInput("roughness").Get() == pytest.approx(1 - model.mat_shininess[matid])
    colliders = _prims(stage, UsdPhysics.CollisionAPI)
    purposes = {UsdGeom.Imageable(prim).GetPurposeAttr().Get() for prim in colliders}
    assert purposes == {"guide"}  # group 3: hidden as in MuJoCo's viewer


def test_cameras_keep_mujocos_vertical_field_of_view(exported) -> None:
    model, data, stage = exported
    cameras = [prim for prim in stage.Traverse() if prim.IsA(UsdGeom.Camera)]
    assert len(cameras) == model.ncam
    mujoco.mj_forward(model, data)
    for cam, prim in enumerate(cameras):
        camera = UsdGeom.Camera(prim).GetCamera(Usd.TimeCode.Default())
        fovy = 2 * math.degrees(math.atan(camera.verticalAperture / 2 / camera.focalLength))
        assert fovy == pytest.approx(model.cam_fovy[cam])
        world = _world(prim)
        np.testing.assert_allclose(world.ExtractTranslation(), data.cam_xpos[cam], atol=1e-9)
        rotation = np.array(world.ExtractRotationMatrix()).T
        np.testing.assert_allclose(rotation, data.cam_xmat[cam].reshape(3, 3), atol=1e-9)


def test_site_sensors_are_documented_prims_at_their_sites(tmp_path: Path) -> None:
    model, data, stage = _load(models_dir() / MODELS["so100"], tmp_path / "so100.usd")
    sensors = {prim.GetName(): prim for prim in stage.Traverse() if prim.HasAttribute("joshua:sensor:type")}
    site_sensors = [s for s in range(model.nsensor) if model.sensor_objtype[s] == mujoco.mjtObj.mjOBJ_SITE]
    assert sorted(sensors) == sorted(model.sensor(s).name for s in site_sensors)
    for sensor in site_sensors:
        prim = sensors[model.sensor(sensor).name]
        site = model.sensor_objid[sensor]
        assert prim.GetAttribute("joshua:sensor:site").Get() == model.site(site).name
        np.testing.assert_allclose(_world(prim).ExtractTranslation(), data.site_xpos[site], atol=1e-9)
    assert sensors["gripper_touch_moving"].GetAttribute("joshua:sensor:type").Get() == "touch"
    assert sensors["wrist_gyro"].GetAttribute("joshua:sensor:type").Get() == "gyro"
    schemas = stage.GetPrimAtPath("/so_arm100/moving_jaw").GetMetadata("apiSchemas").GetAddedOrExplicitItems()
    assert "PhysxContactReportAPI" in schemas  # in the metadata, whether the PhysX schemas are registered or not
    assert sensors["gripper_touch_moving"].GetTypeName() == "IsaacContactSensor"  # Isaac's contact sensor
    imu = stage.GetPrimAtPath("/so_arm100/fixed_jaw/sensors/wrist_imu")
    assert imu.GetTypeName() == "IsaacImuSensor" and imu.GetAttribute("enabled").Get()
    assert list(imu.GetAttribute("joshua:sensor:imuOf").Get()) == ["wrist_accel", "wrist_gyro"]
    np.testing.assert_allclose(_world(imu).ExtractTranslation(), data.site("wrist").xpos, atol=1e-9)
    notes = stage.GetDefaultPrim().GetAttribute("joshua:notExported").Get()
    assert len(notes) == 12 and all("only sensors at sites" in note for note in notes)
