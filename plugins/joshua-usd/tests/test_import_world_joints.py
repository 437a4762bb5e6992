"""Joints attached to the static world as UsdPhysics defines it: a body rel without a target, or one whose target is
in no rigid body (an asset's root Xform), is the world, and localPos/localRot are in the target's frame; a target
inside a rigid body (a child Xform) stands for that body. Checked against the stage's own transforms and against
UsdPhysics' reference parser (UsdPhysics.LoadUsdPhysicsFromRange), which resolves the rels the same way."""

from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path

import mujoco
import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdPhysics

sys.path.insert(0, str(Path(__file__).parent))

from usd_stages import body, joint_local, new_stage, place, to_mujoco, world_matrix  # noqa: E402

from joshua_usd.importer import import_usd  # noqa: E402

TOLERANCE = 1e-6  # metres: float32 localPos/localRot against double transforms


def reference_joints(stage: Usd.Stage) -> dict[str, tuple[str, str]]:
    """(body0, body1) of every joint as UsdPhysics' reference parser resolves them ('' is the world)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # renamed in later USD releases, same parser
        parsed = UsdPhysics.LoadUsdPhysicsFromRange(stage, ["/"])
    found = {}
    for key, (paths, descs) in parsed.items():
        if "Joint" in str(key):
            for path, desc in zip(paths, descs, strict=True):
                found[str(path)] = (str(desc.body0), str(desc.body1))
    return found


def robot_on_an_xform(path: Path, up: str = "Z") -> tuple[Usd.Stage, Gf.Vec3d]:
    """/robot: an Xform (no RigidBodyAPI) turned and moved; base welded to it by a FixedJoint whose body0 is /robot
    (localPos0 in /robot's frame), arm hinged to base through a frame Xform inside base. Returns the hinge's
    world position."""
    stage = new_stage(path, up=up)
    robot = UsdGeom.Xform.Define(stage, "/robot").GetPrim()
    place(robot, (0.3, -0.2, 0.1), Gf.Rotation(Gf.Vec3d(0, 0, 1), 90))
    stage.SetDefaultPrim(robot)
    UsdPhysics.ArticulationRootAPI.Apply(robot)
    base = body(stage, "/robot/base", (0.5, 0, 0.05))
    arm = body(stage, "/robot/arm", (0.5, 0, 0.4))
    fixed = UsdPhysics.FixedJoint.Define(stage, "/robot/root_joint")
    fixed.CreateBody0Rel().SetTargets([robot.GetPath()])
    fixed.CreateBody1Rel().SetTargets([base.GetPath()])
    fixed.CreateLocalPos0Attr(Gf.Vec3f(0.5, 0, 0.05))  # base's origin, in /robot's frame
    fixed.CreateLocalRot0Attr(Gf.Quatf(1, 0, 0, 0))
    fixed.CreateLocalPos1Attr(Gf.Vec3f(0, 0, 0))
    fixed.CreateLocalRot1Attr(Gf.Quatf(1, 0, 0, 0))
    frame = UsdGeom.Xform.Define(stage, "/robot/base/hinge_frame").GetPrim()
    place(frame, (0, 0, 0.2))
    hinge_world = world_matrix(frame).Transform(Gf.Vec3d(0, 0, 0))
    hinge = UsdPhysics.RevoluteJoint.Define(stage, "/robot/hinge")
    hinge.CreateBody0Rel().SetTargets([frame.GetPath()])
    hinge.CreateBody1Rel().SetTargets([arm.GetPath()])
    hinge.CreateAxisAttr("Y")
    hinge.CreateLowerLimitAttr(-45.0)
    hinge.CreateUpperLimitAttr(60.0)
    hinge.CreateLocalPos0Attr(Gf.Vec3f(0, 0, 0))  # the frame Xform's origin
    hinge.CreateLocalRot0Attr(Gf.Quatf(1, 0, 0, 0))
    local_pos, local_rot = joint_local(arm, hinge_world, world_matrix(frame).ExtractRotation())
    hinge.CreateLocalPos1Attr(local_pos)
    hinge.CreateLocalRot1Attr(local_rot)
    stage.Save()
    return stage, hinge_world


@pytest.mark.parametrize("up", ["Z", "Y"])
def test_a_joint_to_a_prim_that_is_no_rigid_body_attaches_to_the_world(tmp_path: Path, up: str) -> None:
    stage, hinge_world = robot_on_an_xform(tmp_path / "robot.usda", up)
    assert reference_joints(stage) == {
        "/robot/root_joint": ("", "/robot/base"),
        "/robot/hinge": ("/robot/base", "/robot/arm"),
    }
    imported = import_usd(tmp_path / "robot.usda")
    model = imported.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert model.body("base").parentid[0] == 0 and model.body("base").jntnum[0] == 0  # welded to the world
    assert model.njnt == 1 and model.jnt_type[0] == mujoco.mjtJoint.mjJNT_HINGE
    np.testing.assert_allclose(model.jnt_range[0], np.radians([-45.0, 60.0]), atol=1e-6)
    for name in ("base", "arm"):
        expected = to_mujoco(stage, world_matrix(stage.GetPrimAtPath(f"/robot/{name}")).ExtractTranslation())
        np.testing.assert_allclose(data.body(name).xpos, expected, atol=TOLERANCE)
    np.testing.assert_allclose(data.joint("hinge").xanchor, to_mujoco(stage, hinge_world), atol=TOLERANCE)
    axis = world_matrix(stage.GetPrimAtPath("/robot/base/hinge_frame")).TransformDir(Gf.Vec3d(0, 1, 0))
    np.testing.assert_allclose(data.joint("hinge").xaxis, to_mujoco(stage, axis, direction=True), atol=TOLERANCE)
    assert not [warning for warning in imported.report.warnings if "disagree" in warning]


def test_the_world_frame_of_a_non_body_target_places_the_body(tmp_path: Path) -> None:
    """localPos0 in the root Xform's frame, not the stage's: the base lands where that frame puts it, even where
    the base's own transform says otherwise (the joint frames rule, with a warning)."""
    stage, _ = robot_on_an_xform(tmp_path / "robot.usda")
    stage.GetPrimAtPath("/robot/root_joint").GetAttribute("physics:localPos0").Set(Gf.Vec3f(0.5, 0, 0.15))
    stage.Save()
    imported = import_usd(tmp_path / "robot.usda")
    data = mujoco.MjData(model := imported.spec.compile())
    mujoco.mj_forward(model, data)
    expected = world_matrix(stage.GetPrimAtPath("/robot")).Transform(Gf.Vec3d(0.5, 0, 0.15))
    np.testing.assert_allclose(data.body("base").xpos, to_mujoco(stage, expected), atol=TOLERANCE)
    assert any("/robot/root_joint: the joint frames" in warning for warning in imported.report.warnings)


def test_a_revolute_joint_to_the_world_through_an_xform_hinges_the_body(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "door.usda")
    mount = UsdGeom.Xform.Define(stage, "/World/mount").GetPrim()
    place(mount, (1, 2, 0), Gf.Rotation(Gf.Vec3d(0, 0, 1), 30))
    door = body(stage, "/World/door", (1, 2, 1))
    hinge = UsdPhysics.RevoluteJoint.Define(stage, "/World/hinge")
    hinge.CreateBody0Rel().SetTargets([mount.GetPath()])
    hinge.CreateBody1Rel().SetTargets([door.GetPath()])
    hinge.CreateAxisAttr("X")
    hinge.CreateLocalPos0Attr(Gf.Vec3f(0, 0, 1))
    local_pos, local_rot = joint_local(door, (1, 2, 1), world_matrix(mount).ExtractRotation())
    hinge.CreateLocalPos1Attr(local_pos)
    hinge.CreateLocalRot1Attr(local_rot)
    stage.Save()
    assert reference_joints(stage) == {"/World/hinge": ("", "/World/door")}
    model = import_usd(tmp_path / "door.usda").spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.joint("hinge").xanchor, [1, 2, 1], atol=TOLERANCE)
    turned = [math.cos(math.radians(30)), math.sin(math.radians(30)), 0]
    np.testing.assert_allclose(data.joint("hinge").xaxis, turned, atol=TOLERANCE)


def test_joints_within_one_body_or_only_to_the_world_are_warned_and_ignored(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "odd.usda")
    body(stage, "/World/crate", (0, 0, 1))
    UsdGeom.Xform.Define(stage, "/World/crate/handle")
    UsdGeom.Xform.Define(stage, "/World/shelf")
    for name, targets in (("self", ("/World/crate", "/World/crate/handle")), ("static", ("/World/shelf", ""))):
        made = UsdPhysics.FixedJoint.Define(stage, f"/World/{name}")
        made.CreateBody0Rel().SetTargets([targets[0]])
        if targets[1]:
            made.CreateBody1Rel().SetTargets([targets[1]])
    stage.Save()
    imported = import_usd(tmp_path / "odd.usda")
    model = imported.spec.compile()
    assert model.body("crate").jntnum[0] == 1 and model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    assert "/World/self: body0 and body1 are both in the rigid body </World/crate>: ignored" in imported.report.warnings
    assert any(warning.startswith("/World/static: neither body0 nor body1") for warning in imported.report.warnings)
