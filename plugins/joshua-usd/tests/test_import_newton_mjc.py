"""Newton's (NewtonJointAPI, NewtonSceneAPI, NewtonCollisionAPI, NewtonMassAPI) and MuJoCo's (MjcJointAPI,
MjcSceneAPI, MjcCollisionAPI) physics attributes, as mujoco-usd-converter writes them: each in its schema's units,
before PhysX's where both are authored, and `joshua usd inspect` listing what the import did not use."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from pxr import Sdf, Usd, UsdPhysics, UsdShade

sys.path.insert(0, str(Path(__file__).parent))

from usd_stages import body, joint, new_stage  # noqa: E402

from joshua_core.errors import ModelError  # noqa: E402
from joshua_usd.importer import compile_spec, import_usd  # noqa: E402
from joshua_usd.inspect import describe  # noqa: E402

T = Sdf.ValueTypeNames
TOLERANCE = 1e-6  # relative: USD's float attributes carry 7 digits (and 1e-6 absolute for positions, metres)


def author(prim: Usd.Prim, api: str, **values: tuple[Sdf.ValueTypeName, object]) -> None:
    """Apply the (unregistered) API schema `api` and author `values` (name with __ for ':') as the converter does."""
    prim.AddAppliedSchema(api)
    for name, (kind, value) in values.items():
        prim.CreateAttribute(name.replace("__", ":"), kind, custom=False).Set(value)


def arm(path: Path, meters_per_unit: float = 1.0) -> tuple[Usd.Stage, Usd.Prim, Usd.Prim]:
    """A welded base, a hinge (about Z) to `arm` and a slider (along X) from `arm` to `carriage`."""
    u = 1 / meters_per_unit
    stage = new_stage(path, "Z", meters_per_unit)
    base = body(stage, "/World/base", size=0.1 * u)
    link = body(stage, "/World/arm", (0.3 * u, 0, 0), size=0.1 * u)
    carriage = body(stage, "/World/carriage", (0.6 * u, 0, 0), size=0.1 * u)
    joint(stage, UsdPhysics.FixedJoint, "/World/weld", None, base, (0, 0, 0))
    hinge = joint(stage, UsdPhysics.RevoluteJoint, "/World/hinge", base, link, (0.15 * u, 0, 0), axis="Z").GetPrim()
    slider = joint(stage, UsdPhysics.PrismaticJoint, "/World/slider", link, carriage, (0.45 * u, 0, 0), axis="X")
    return stage, hinge, slider.GetPrim()


def compiled(path: Path) -> mujoco.MjModel:
    imported = import_usd(path)
    return compile_spec(imported.spec, imported.report)


def test_newton_joint_values_in_stage_units_before_physx_and_mjc(tmp_path: Path) -> None:
    stage, hinge, slider = arm(tmp_path / "arm.usda", meters_per_unit=0.01)  # centimetres
    author(hinge, "NewtonJointAPI", newton__armature=(T.Float, 2000.0), newton__damping=(T.Float, 30.0))
    author(hinge, "NewtonJointAPI", newton__friction=(T.Float, 5000.0))
    author(hinge, "MjcJointAPI", mjc__armature=(T.Double, 7.0), mjc__frictionloss=(T.Double, 7.0))
    hinge.AddAppliedSchema("PhysxJointAxisAPI:angular")
    hinge.CreateAttribute("physxJointAxis:angular:armature", T.Float).Set(9.0)
    author(slider, "MjcJointAPI", mjc__armature=(T.Double, 0.5), mjc__damping=(T.Double, 3.0))
    author(slider, "MjcJointAPI", mjc__frictionloss=(T.Double, 1.5))
    stage.Save()
    model = compiled(tmp_path / "arm.usda")
    hinge_dof, slider_dof = model.joint("hinge").dofadr[0], model.joint("slider").dofadr[0]
    # kg cm^2 -> kg m^2; N cm s/deg -> N m s/rad; N cm -> N m. MjcJointAPI's deprecated names are MuJoCo's units.
    expected = {
        "armature": (2000.0 * 1e-4, 0.5),
        "damping": (30.0 * 1e-4 * 180 / math.pi, 3.0),
        "frictionloss": (5000.0 * 1e-4, 1.5),
    }
    for name, values in expected.items():
        actual = getattr(model, f"dof_{name}")[[hinge_dof, slider_dof]]
        np.testing.assert_allclose(actual, values, rtol=TOLERANCE, err_msg=name)
    text = describe(tmp_path / "arm.usda")
    assert "physics attributes not used (3):" in text
    for unused in ("mjc:armature = 7", "mjc:frictionloss = 7", "physxJointAxis:angular:armature = 9"):
        assert f"  /World/hinge: {unused}\n" in text


def test_mjc_reference_spring_and_limit_softness(tmp_path: Path) -> None:
    stage, hinge, slider = arm(tmp_path / "arm.usda")
    UsdPhysics.RevoluteJoint(hinge).CreateLowerLimitAttr(-90.0)
    UsdPhysics.RevoluteJoint(hinge).CreateUpperLimitAttr(90.0)
    author(hinge, "MjcJointAPI", mjc__ref=(T.Double, 30.0), mjc__springref=(T.Double, 10.0))
    author(hinge, "MjcJointAPI", mjc__stiffness=(T.Double, 4.0), mjc__solreflimit=(T.DoubleArray, [0.01, 0.5]))
    author(hinge, "MjcJointAPI", mjc__margin=(T.Double, 0.02), mjc__group=(T.Int, 3))
    author(
        slider, "MjcJointAPI", mjc__ref=(T.Double, 0.05), mjc__solimpfriction=(T.DoubleArray, [0.8, 0.9, 0.01, 0.5, 2])
    )
    stage.Save()
    model = compiled(tmp_path / "arm.usda")
    hinge_joint, slider_joint = model.joint("hinge"), model.joint("slider")
    # Hinge angles in degrees (mjc:compiler:angle's fallback); the slider's in metres.
    np.testing.assert_allclose(
        model.qpos0[[hinge_joint.qposadr[0], slider_joint.qposadr[0]]], [math.radians(30), 0.05], atol=1e-6
    )
    np.testing.assert_allclose(model.qpos_spring[hinge_joint.qposadr[0]], math.radians(10))
    np.testing.assert_allclose(hinge_joint.range, np.radians([-90, 90]))
    assert hinge_joint.stiffness[0] == 4.0 and hinge_joint.margin[0] == pytest.approx(0.02)
    assert hinge_joint.group[0] == 3
    np.testing.assert_allclose(hinge_joint.solref, [0.01, 0.5])
    np.testing.assert_allclose(model.dof_solimp[slider_joint.dofadr[0]], [0.8, 0.9, 0.01, 0.5, 2])
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)  # at qpos0 the bodies stand where the stage puts them
    np.testing.assert_allclose(data.body("carriage").xpos, [0.6, 0, 0], atol=1e-6)


def test_scene_newton_and_mjc_options_before_physx(tmp_path: Path) -> None:
    stage, hinge, _ = arm(tmp_path / "arm.usda")
    scene = stage.GetPrimAtPath("/World/physicsScene")
    scene.AddAppliedSchema("NewtonSceneAPI")
    author(scene, "MjcSceneAPI", mjc__option__integrator=(T.Token, "rk4"), mjc__option__cone=(T.Token, "elliptic"))
    author(scene, "MjcSceneAPI", mjc__option__o_solref=(T.DoubleArray, [0.03, 1.5]), mjc__flag__contact=(T.Bool, False))
    author(scene, "MjcSceneAPI", mjc__flag__energy=(T.Bool, True), newton__gravityEnabled=(T.Bool, False))
    author(scene, "MjcSceneAPI", newton__maxSolverIterations=(T.Int, 20))
    scene.CreateAttribute("joshua:option:integrator", T.Token, custom=True).Set("implicitfast")
    scene.CreateAttribute("physxScene:timeStepsPerSecond", T.UInt).Set(60)
    UsdPhysics.ArticulationRootAPI.Apply(stage.GetPrimAtPath("/World/base"))
    stage.GetPrimAtPath("/World/base").CreateAttribute("physxArticulation:solverPositionIterationCount", T.Int).Set(4)
    stage.Save()
    model = compiled(tmp_path / "arm.usda")
    assert model.opt.timestep == pytest.approx(1 / 60)  # PhysX's, authored, before NewtonSceneAPI's fallback
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4 and model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
    assert model.opt.iterations == 20
    np.testing.assert_allclose(model.opt.o_solref, [0.03, 1.5])
    assert model.opt.disableflags == mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_GRAVITY
    assert model.opt.enableflags == mujoco.mjtEnableBit.mjENBL_ENERGY
    text = describe(tmp_path / "arm.usda")
    assert "  /World/physicsScene: joshua:option:integrator" not in text  # not a physics schema's: never listed
    assert "  /World/base: physxArticulation:solverPositionIterationCount = 4\n" in text

    scene.CreateAttribute("newton:timeStepsPerSecond", T.Int, custom=False).Set(250)
    stage.Save()
    assert compiled(tmp_path / "arm.usda").opt.timestep == pytest.approx(0.004)
    scene.RemoveProperty("newton:timeStepsPerSecond")
    scene.RemoveProperty("physxScene:timeStepsPerSecond")
    stage.Save()
    assert compiled(tmp_path / "arm.usda").opt.timestep == pytest.approx(0.001)  # NewtonSceneAPI's 1000 Hz


def test_newton_collider_and_material_before_physx(tmp_path: Path) -> None:
    stage, _, _ = arm(tmp_path / "arm.usda", meters_per_unit=0.01)
    box = stage.GetPrimAtPath("/World/arm/box")
    author(box, "NewtonCollisionAPI", newton__contactMargin=(T.Float, 2.0), newton__contactGap=(T.Float, 0.5))
    author(box, "MjcCollisionAPI", mjc__condim=(T.Int, 6), mjc__solref=(T.DoubleArray, [0.01, 0.8]))
    box.CreateAttribute("physxCollision:contactOffset", T.Float).Set(3.0)
    material = UsdPhysics.MaterialAPI.Apply(stage.DefinePrim("/World/rubber", "Material"))
    material.CreateDynamicFrictionAttr(0.9)
    material.CreateStaticFrictionAttr(0.9)
    author(material.GetPrim(), "NewtonMaterialAPI", newton__torsionalFriction=(T.Float, 0.02))
    author(material.GetPrim(), "MjcMaterialAPI", mjc__rollingfriction=(T.Double, 0.003))
    UsdShade.MaterialBindingAPI.Apply(box).Bind(UsdShade.Material(material.GetPrim()), materialPurpose="physics")
    author(
        stage.GetPrimAtPath("/World/arm"), "NewtonMassAPI", newton__inertia=(T.DoubleArray, [4e4, 5e4, 6e4, 0, 0, 0])
    )
    UsdPhysics.MassAPI.Apply(stage.GetPrimAtPath("/World/arm")).CreateMassAttr(2.0)
    stage.Save()
    model = compiled(tmp_path / "arm.usda")
    geom = model.geom("arm/box")
    np.testing.assert_allclose([geom.margin[0], geom.gap[0]], [0.02, 0.005], rtol=TOLERANCE)
    assert geom.condim[0] == 6
    np.testing.assert_allclose(geom.solref, [0.01, 0.8])
    np.testing.assert_allclose(geom.friction, [0.9, 0.02, 0.003], rtol=TOLERANCE)
    np.testing.assert_allclose(np.sort(model.body("arm").inertia), [4.0, 5.0, 6.0], rtol=TOLERANCE)  # kg cm^2 -> m^2
    assert "  /World/arm/box: physxCollision:contactOffset = 3\n" in describe(tmp_path / "arm.usda")


@pytest.mark.parametrize(
    ("name", "kind", "value", "message"),
    [
        ("newton:damping", T.Float, -1.0, "newton:damping: must not be negative, got -1.0"),
        ("mjc:solreflimit", T.DoubleArray, [0.02], "mjc:solreflimit: must be 2 numbers, got"),
        ("mjc:actuatorfrclimited", T.Token, "maybe", "mjc:actuatorfrclimited: must be false, true or auto, got maybe"),
    ],
)
def test_bad_values_are_one_line_errors(tmp_path: Path, name: str, kind: Sdf.ValueTypeName, value, message) -> None:
    stage, hinge, _ = arm(tmp_path / "arm.usda")
    hinge.CreateAttribute(name, kind, custom=False).Set(value)
    stage.Save()
    with pytest.raises(ModelError) as raised:
        import_usd(tmp_path / "arm.usda")
    assert f"/World/hinge: {message}" in str(raised.value) and "\n" not in str(raised.value)


def test_velocity_and_limit_spring_are_listed_unused(tmp_path: Path) -> None:
    stage, hinge, _ = arm(tmp_path / "arm.usda")
    author(hinge, "NewtonJointAPI", newton__velocityLimit=(T.Float, 90.0), newton__limitStiffness=(T.Float, 100.0))
    stage.Save()
    text = describe(tmp_path / "arm.usda")
    assert "  /World/hinge: newton:limitStiffness = 100\n  /World/hinge: newton:velocityLimit = 90\n" in text
    assert "  /World/hinge: newton:velocityLimit 90 is not enforced by MuJoCo" in text
