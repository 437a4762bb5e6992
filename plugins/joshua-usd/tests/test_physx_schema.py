"""The PhysX USD schemas (physx-usd-schemas, the `physx` extra) with usd-core: every PhysX API schema and attribute
the exporter writes is theirs with their type, the check names each problem in one line, and attribute names come
from the schemas' definitions."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from pxr import Sdf, Usd, UsdPhysics

from joshua_core.resources import models_dir
from joshua_usd import physx_schema
from joshua_usd.inspect import describe

sys.path.insert(0, str(Path(__file__).parent))

from usd_stages import body, joint, new_stage  # noqa: E402

INT = Sdf.ValueTypeNames.Int
pytestmark = pytest.mark.skipif(not physx_schema.registered(), reason=physx_schema.missing_reason())


@pytest.mark.parametrize("name", ["so100", "ant", "trileg"])
def test_the_exported_robots_apply_only_physx_schemas_and_attributes_with_their_types(name: str) -> None:
    stage = Usd.Stage.Open(str(models_dir() / "isaac" / f"{name}.usd"))
    assert physx_schema.check_stage(stage) == []
    applied = {api for prim in stage.TraverseAll() for api in prim.GetAppliedSchemas() if api.startswith("Physx")}
    assert {api.partition(":")[0] for api in applied} >= {"PhysxSceneAPI", "PhysxArticulationAPI", "PhysxMaterialAPI"}


def test_a_ball_joint_gets_the_three_rotation_axes_physx_reads(tmp_path: Path) -> None:
    from joshua_usd.exporter import export_model

    (tmp_path / "ball.xml").write_text(
        "<mujoco><worldbody><body><joint type='ball' armature='0.1' damping='2'/><geom size='0.1'/></body>"
        "</worldbody></mujoco>"
    )
    stage = Usd.Stage.Open(str(export_model(tmp_path / "ball.xml", tmp_path / "ball.usda")))
    assert physx_schema.check_stage(stage) == []
    ball = next(prim for prim in stage.Traverse() if prim.IsA(UsdPhysics.SphericalJoint))
    assert [api for api in ball.GetAppliedSchemas() if api.startswith("Physx")] == [
        f"PhysxJointAxisAPI:{axis}" for axis in ("rotX", "rotY", "rotZ")
    ]
    for axis in ("rotX", "rotY", "rotZ"):
        assert ball.GetAttribute(f"physxJointAxis:{axis}:armature").Get() == pytest.approx(0.1, rel=1e-6)


def test_each_problem_is_one_line_naming_prim_and_attribute(tmp_path: Path) -> None:
    stage = Usd.Stage.CreateInMemory()
    prim = stage.DefinePrim("/robot")
    prim.AddAppliedSchema("PhysxJointAPI")  # removed from the PhysX schemas
    prim.AddAppliedSchema("PhysxArticulationAPI")
    # as another tool writes it: with the schemas registered, CreateAttribute would take the schema's bool
    Sdf.AttributeSpec(stage.GetRootLayer().GetPrimAtPath("/robot"), "physxArticulation:enabledSelfCollisions", INT)
    prim.CreateAttribute("physxJoint:armature", Sdf.ValueTypeNames.Float).Set(0.1)
    prim.CreateAttribute("physxCollision:restOffset", Sdf.ValueTypeNames.Float).Set(0.0)  # API not applied
    prim.CreateAttribute("joshua:option:cone", Sdf.ValueTypeNames.Token).Set("elliptic")  # not PhysX's: not checked
    assert physx_schema.check_stage(stage) == [
        "/robot: PhysxJointAPI is not an applied API schema of the PhysX schemas",
        "/robot: physxArticulation:enabledSelfCollisions is int, the PhysX schema's is bool",
        "/robot: physxCollision:restOffset is not defined by an applied PhysX API schema",
        "/robot: physxJoint:armature is not defined by an applied PhysX API schema",
    ]


def test_attribute_names_come_from_the_schema_definitions() -> None:
    assert physx_schema.attribute_name("PhysxJointAxisAPI", "armature", "rotY") == "physxJointAxis:rotY:armature"
    assert physx_schema.attribute_name("PhysxSceneAPI", "timeStepsPerSecond") == "physxScene:timeStepsPerSecond"
    for api, name, instance in [
        ("PhysxJointAPI", "armature", ""),  # gone from the schemas
        ("PhysxCollisionAPI", "offset", ""),
        ("PhysxJointAxisAPI", "armature", ""),  # multiple-apply: needs an instance
    ]:
        with pytest.raises(physx_schema.SchemaMismatch):
            physx_schema.attribute_name(api, name, instance)


def test_inspect_lists_the_problems_before_the_warnings(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "robot.usda", "Z", 1.0)
    base = body(stage, "/World/robot/base", (0, 0, 1), size=0.1)
    arm = body(stage, "/World/robot/arm", (0.2, 0, 1), size=0.1)
    hinge = joint(stage, UsdPhysics.RevoluteJoint, "/World/robot/elbow", base, arm, (0.1, 0, 1), axis="Y")
    hinge.GetPrim().CreateAttribute("physxJoint:armature", Sdf.ValueTypeNames.Float).Set(0.05)
    stage.Save()
    text = describe(tmp_path / "robot.usda")
    assert "\nPhysX schemas (1 problems):\n  /World/robot/elbow: physxJoint:armature is not defined" in text
    assert "armature 0.05 kg m^2" in text  # still imported: Isaac assets before the PhysX schemas write it
    assert "PhysX schemas (0 problems):\nphysics attributes not used (0):\nwarnings (0):" in describe(
        models_dir() / "isaac" / "so100.usd"
    )
