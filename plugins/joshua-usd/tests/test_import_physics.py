"""Importer physics: drives per degree -> SI actuators, MassAPI masses/inertia/principal axes and density
fallback, friction from physics materials, scene gravity and time step, PhysX joint and articulation attributes."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade

sys.path.insert(0, str(Path(__file__).parent))

from usd_stages import body, joint, new_stage  # noqa: E402

from joshua_usd.importer import import_usd  # noqa: E402

DEG = 180 / math.pi


def pendulum(path: Path, meters_per_unit: float = 1.0) -> tuple[Usd.Stage, Usd.Prim, Usd.Prim]:
    """A welded base with a hinge (about Z) to `arm` and a slider (along X) from `arm` to `carriage`."""
    u = 1 / meters_per_unit
    stage = new_stage(path, "Z", meters_per_unit)
    base = body(stage, "/World/base", size=0.1 * u)
    arm = body(stage, "/World/arm", (0.3 * u, 0, 0), size=0.1 * u)
    carriage = body(stage, "/World/carriage", (0.6 * u, 0, 0), size=0.1 * u)
    joint(stage, UsdPhysics.FixedJoint, "/World/weld", None, base, (0, 0, 0))
    hinge = joint(stage, UsdPhysics.RevoluteJoint, "/World/hinge", base, arm, (0.15 * u, 0, 0), axis="Z")
    slider = joint(stage, UsdPhysics.PrismaticJoint, "/World/slider", arm, carriage, (0.45 * u, 0, 0), axis="X")
    return stage, hinge, slider


def drive(prim: Usd.Prim, instance: str, **values: float) -> None:
    api = UsdPhysics.DriveAPI.Apply(prim, instance)
    for name, value in values.items():
        getattr(api, f"Create{name[0].upper()}{name[1:]}Attr")(value)


@pytest.mark.parametrize("meters_per_unit", [1.0, 0.01], ids=["metres", "centimetres"])
def test_drives_per_degree_become_si_actuators_named_after_joints(tmp_path: Path, meters_per_unit: float) -> None:
    stage, hinge, slider = pendulum(tmp_path / "drives.usda", meters_per_unit)
    drive(hinge, "angular", stiffness=100.0, damping=2.0, maxForce=50.0, targetPosition=30.0)
    drive(slider, "linear", damping=40.0, targetVelocity=5.0)
    stage.Save()
    imported = import_usd(tmp_path / "drives.usda")
    model = imported.spec.compile()
    torque = meters_per_unit**2  # kg * unit^2 / s^2 per N m
    assert [model.actuator(i).name for i in range(model.nu)] == ["hinge", "slider"]
    hinge_actuator, slider_actuator = model.actuator("hinge"), model.actuator("slider")
    assert hinge_actuator.gainprm[0] == pytest.approx(100 * DEG * torque)
    np.testing.assert_allclose(hinge_actuator.biasprm[:3], [0, -100 * DEG * torque, -2 * DEG * torque])
    np.testing.assert_allclose(hinge_actuator.forcerange, [-50 * torque, 50 * torque])
    assert slider_actuator.gainprm[0] == pytest.approx(40.0)  # N/(m/s): kg*unit/s^2 per unit/s is kg/s
    assert slider_actuator.biasprm[1] == 0 and slider_actuator.biasprm[2] == pytest.approx(-40.0)
    np.testing.assert_allclose(model.key("drive_targets").ctrl, [math.radians(30), 5 * meters_per_unit])


def test_a_position_drive_holds_its_target(tmp_path: Path) -> None:
    stage, hinge, _ = pendulum(tmp_path / "hold.usda")
    drive(hinge, "angular", stiffness=2.0, damping=0.2, targetPosition=-40.0)
    stage.Save()
    model = import_usd(tmp_path / "hold.usda").spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("drive_targets").id)
    mujoco.mj_step(model, data, 3000)
    assert data.joint("hinge").qpos[0] == pytest.approx(math.radians(-40), abs=0.02)


def test_mass_api_sets_mass_inertia_principal_axes_and_center_of_mass(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "mass.usda")
    explicit = body(stage, "/World/explicit", (0, 0, 1))
    mass = UsdPhysics.MassAPI.Apply(explicit)
    mass.CreateMassAttr(3.0)
    mass.CreateDiagonalInertiaAttr(Gf.Vec3f(0.2, 0.3, 0.4))
    axes = Gf.Rotation(Gf.Vec3d(1, 2, 3), 50).GetQuat()
    mass.CreatePrincipalAxesAttr(Gf.Quatf(axes))
    mass.CreateCenterOfMassAttr(Gf.Vec3f(0.01, 0.02, -0.03))
    UsdPhysics.MassAPI.Apply(body(stage, "/World/heavy", (1, 0, 1), size=0.2)).CreateMassAttr(2.0)
    UsdPhysics.MassAPI.Apply(body(stage, "/World/dense", (2, 0, 1), size=0.2)).CreateDensityAttr(500.0)
    body(stage, "/World/default", (3, 0, 1), size=0.2)
    stage.Save()
    model = import_usd(tmp_path / "mass.usda").spec.compile()
    assert model.body("explicit").mass[0] == pytest.approx(3.0)
    tensor = np.zeros(9)
    mujoco.mju_quat2Mat(tensor, model.body("explicit").iquat)
    rotation = tensor.reshape(3, 3)
    gf_axes = np.array(Gf.Matrix3d(Gf.Rotation(Gf.Vec3d(1, 2, 3), 50))).T  # column vectors
    np.testing.assert_allclose(
        rotation @ np.diag(model.body("explicit").inertia) @ rotation.T,
        gf_axes @ np.diag([0.2, 0.3, 0.4]) @ gf_axes.T,
        atol=1e-6,
    )
    np.testing.assert_allclose(model.body("explicit").ipos, [0.01, 0.02, -0.03], atol=1e-7)
    assert model.body("heavy").mass[0] == pytest.approx(2.0)
    np.testing.assert_allclose(model.body("heavy").inertia, [2.0 * 2 * 0.2**2 / 12] * 3)
    assert model.body("dense").mass[0] == pytest.approx(500 * 0.2**3)
    assert model.body("default").mass[0] == pytest.approx(1000 * 0.2**3)  # UsdPhysics' default density


def test_a_body_without_colliders_or_mass_gets_a_warned_fallback(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "empty.usda")
    UsdPhysics.RigidBodyAPI.Apply(UsdGeom.Xform.Define(stage, "/World/ghost").GetPrim())
    stage.Save()
    imported = import_usd(tmp_path / "empty.usda")
    assert imported.spec.compile().body("ghost").mass[0] == pytest.approx(1.0)
    assert any(w.startswith("/World/ghost: no collider to weigh") for w in imported.report.warnings)


def test_friction_comes_from_the_bound_physics_material(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "friction.usda")
    cube = body(stage, "/World/cube", (0, 0, 1))
    material = UsdShade.Material.Define(stage, "/World/rubber")
    api = UsdPhysics.MaterialAPI.Apply(material.GetPrim())
    api.CreateDynamicFrictionAttr(0.7)
    api.CreateStaticFrictionAttr(0.9)
    binding = UsdShade.MaterialBindingAPI.Apply(cube)
    binding.Bind(material, UsdShade.Tokens.weakerThanDescendants, "physics")
    stage.Save()
    imported = import_usd(tmp_path / "friction.usda")
    assert imported.spec.compile().geom("box").friction[0] == pytest.approx(0.7)
    assert any(w.startswith("/World/rubber: staticFriction 0.9") for w in imported.report.warnings)


def test_scene_gravity_and_time_step_in_a_y_up_centimetre_stage(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "scene.usda", "Y", 0.01)
    scene = UsdPhysics.Scene(stage.GetPrimAtPath("/World/physicsScene"))
    scene.CreateGravityDirectionAttr(Gf.Vec3f(1, -1, 0))
    scene.CreateGravityMagnitudeAttr(981.0)
    scene.GetPrim().CreateAttribute("physxScene:timeStepsPerSecond", Sdf.ValueTypeNames.UInt).Set(120)
    stage.Save()
    model = import_usd(tmp_path / "scene.usda").spec.compile()
    np.testing.assert_allclose(model.opt.gravity, 9.81 * np.array([1, 0, -1]) / math.sqrt(2))
    assert model.opt.timestep == pytest.approx(1 / 120)


def test_physx_joint_and_articulation_attributes(tmp_path: Path) -> None:
    stage, hinge, slider = pendulum(tmp_path / "physx.usda")
    hinge.CreateAttribute("physxJoint:armature", Sdf.ValueTypeNames.Float).Set(0.05)
    hinge.CreateAttribute("physxJoint:jointFriction", Sdf.ValueTypeNames.Float).Set(0.3)
    slider.CreateAttribute("physxJoint:maxJointVelocity", Sdf.ValueTypeNames.Float).Set(2.0)
    root = stage.GetPrimAtPath("/World/base")
    UsdPhysics.ArticulationRootAPI.Apply(root)
    root.CreateAttribute("physxArticulation:enabledSelfCollisions", Sdf.ValueTypeNames.Bool).Set(False)
    root.CreateAttribute("physxArticulation:solverPositionIterationCount", Sdf.ValueTypeNames.Int).Set(32)
    stage.Save()
    imported = import_usd(tmp_path / "physx.usda")
    model = imported.spec.compile()
    assert model.dof_armature[model.joint("hinge").dofadr[0]] == pytest.approx(0.05)
    assert model.dof_frictionloss[model.joint("hinge").dofadr[0]] == pytest.approx(0.3)
    assert model.opt.iterations == 32
    excluded = {
        frozenset((model.body(int(a)).name, model.body(int(b)).name))
        for a, b in (divmod(int(signature), 1 << 16) for signature in model.exclude_signature)
    }
    assert excluded == {frozenset(pair) for pair in [("base", "arm"), ("base", "carriage"), ("arm", "carriage")]}
    assert any(w.startswith("/World/slider: physxJoint:maxJointVelocity 2") for w in imported.report.warnings)


def test_physx_joint_axis_attributes_are_damping_frictionloss_and_armature(tmp_path: Path) -> None:
    stage, hinge, slider = pendulum(tmp_path / "axis.usda", meters_per_unit=0.01)
    values = {
        "viscousFrictionCoefficient": 0.01,
        "dynamicFrictionEffort": 2e4,
        "staticFrictionEffort": 3e4,
        "armature": 500.0,
    }  # per degree; torques in kg cm^2/s^2, inertia in kg cm^2
    hinge.CreateAttribute("physxJoint:armature", Sdf.ValueTypeNames.Float).Set(9.0)  # the axis' value wins
    for name, value in values.items():
        hinge.CreateAttribute(f"physxJointAxis:angular:{name}", Sdf.ValueTypeNames.Float).Set(value)
    slider.CreateAttribute("physxJointAxis:linear:viscousFrictionCoefficient", Sdf.ValueTypeNames.Float).Set(3.0)
    slider.CreateAttribute("physxJointAxis:linear:staticFrictionEffort", Sdf.ValueTypeNames.Float).Set(40.0)
    stage.Save()
    imported = import_usd(tmp_path / "axis.usda")
    model = imported.spec.compile()
    dof = model.joint("hinge").dofadr[0]
    assert model.dof_damping[dof] == pytest.approx(0.01 * DEG * 1e-4)
    assert model.dof_frictionloss[dof] == pytest.approx(2.0)
    assert model.dof_armature[dof] == pytest.approx(0.05)
    dof = model.joint("slider").dofadr[0]
    assert model.dof_damping[dof] == pytest.approx(3.0)  # kg/s in any length unit
    assert model.dof_frictionloss[dof] == pytest.approx(0.4)  # N: 40 kg cm/s^2
    assert [w for w in imported.report.warnings if "FrictionEffort" in w] == [
        "/World/hinge: staticFrictionEffort 30000 differs from dynamicFrictionEffort 20000: MuJoCo's frictionloss "
        "is the dynamic one"
    ]


def test_collision_offsets_become_margin_and_gap(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "offsets.usda", "Z", 0.01)
    offsets = {"rest": (1.0, None), "both": (0.5, 2.0), "contact": (None, 3.0), "auto": (None, float("-inf"))}
    for name, (rest, contact) in offsets.items():
        box = body(stage, f"/World/{name}", size=10).GetChild("box")
        for kind, value in (("rest", rest), ("contact", contact)):
            if value is not None:
                box.CreateAttribute(f"physxCollision:{kind}Offset", Sdf.ValueTypeNames.Float).Set(value)
    stage.Save()
    model = import_usd(tmp_path / "offsets.usda").spec.compile()
    margins = {name: (model.geom(f"{name}/box").margin[0], model.geom(f"{name}/box").gap[0]) for name in offsets}
    expected = {"rest": (0.01, 0.0), "both": (0.02, 0.015), "contact": (0.03, 0.03), "auto": (0.0, 0.0)}
    for name, value in expected.items():
        np.testing.assert_allclose(margins[name], value, atol=1e-9, err_msg=name)


def test_joshua_attributes_restore_solver_options_gear_and_free_joint_name(tmp_path: Path) -> None:
    stage, hinge, _ = pendulum(tmp_path / "joshua.usda")
    scene = stage.GetPrimAtPath("/World/physicsScene")
    for name, kind, value in (
        ("integrator", "Token", "implicitfast"),
        ("cone", "Token", "cone"),
        ("impratio", "Double", 10.0),
    ):
        scene.CreateAttribute(f"joshua:option:{name}", getattr(Sdf.ValueTypeNames, kind), custom=True).Set(value)
    drive(hinge, "angular", stiffness=4 * 17.8 / DEG, damping=0.0, maxForce=6.0, targetPosition=30.0)
    for name, kind, value in (("", "String", "servo"), (":gear", "Float", 2.0), (":ctrlRange", "Float2", (-1, 1))):
        hinge.CreateAttribute(f"joshua:actuator{name}", getattr(Sdf.ValueTypeNames, kind), custom=True).Set(value)
    floating = body(stage, "/World/float", (0, 0, 2))
    floating.CreateAttribute("joshua:freeJoint", Sdf.ValueTypeNames.String, custom=True).Set("root")
    stage.Save()
    imported = import_usd(tmp_path / "joshua.usda")
    model = imported.spec.compile()
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST and model.opt.impratio == 10.0
    assert model.opt.cone == mujoco.mjtCone.mjCONE_PYRAMIDAL  # "cone" is no cone: warned, default kept
    assert "/World/physicsScene: joshua:option:cone 'cone' is not a MuJoCo cone: ignored" in imported.report.warnings
    servo = model.actuator("servo")
    assert servo.gear[0] == 2.0 and servo.gainprm[0] == pytest.approx(17.8)
    np.testing.assert_allclose(servo.ctrlrange, [-1, 1])
    np.testing.assert_allclose(servo.forcerange, [-3, 3])
    np.testing.assert_allclose(model.key("drive_targets").ctrl, [2 * math.radians(30)])
    assert model.joint("root").type == mujoco.mjtJoint.mjJNT_FREE
