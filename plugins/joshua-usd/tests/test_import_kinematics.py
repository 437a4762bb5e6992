"""Importer kinematics: joint anchors and axes in MuJoCo's world against Gf math on the stage (qpos 0 and a
random pose), units and up axis, fixed and floating bases, fixed joints, reversed and inconsistent joints."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from pxr import Gf, Usd, UsdPhysics

sys.path.insert(0, str(Path(__file__).parent))

from usd_stages import body, joint, new_stage, to_mujoco, world_matrix  # noqa: E402

from joshua_usd.importer import import_usd  # noqa: E402


def compiled(path: Path) -> tuple[mujoco.MjModel, mujoco.MjData, list[str]]:
    imported = import_usd(path)
    model = imported.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data, imported.report.warnings


def rotation(axis: tuple[float, float, float], degrees: float) -> Gf.Rotation:
    return Gf.Rotation(Gf.Vec3d(*axis), degrees)


def arm(path: Path, up: str, meters_per_unit: float) -> Usd.Stage:
    """base (welded to the world) -hinge-> link1 -slide-> link2 -hinge about -Z-> link3, every body and
    joint frame offset and rotated; lengths in stage units."""
    u = 1 / meters_per_unit
    stage = new_stage(path, up, meters_per_unit)
    base = body(stage, "/World/arm/base", (0.1 * u, 0.2 * u, 0.05 * u), rotation((0, 0, 1), 15), 0.1 * u)
    link1 = body(stage, "/World/arm/link1", (0.1 * u, 0.3 * u, 0.3 * u), rotation((1, 1, 0), 40), 0.1 * u)
    link2 = body(stage, "/World/arm/link2", (0.2 * u, 0.4 * u, 0.5 * u), rotation((0, 1, 0), -25), 0.1 * u)
    link3 = body(stage, "/World/arm/link3", (0.3 * u, 0.4 * u, 0.7 * u), None, 0.1 * u)
    joint(stage, UsdPhysics.FixedJoint, "/World/arm/anchor", None, base, (0.1 * u, 0.2 * u, 0))
    moving = (  # (kind, name, parent, child, position, rotation, axis); the wrist's frame is flipped: its Z is -Z
        (UsdPhysics.RevoluteJoint, "shoulder", base, link1, (0.1, 0.25, 0.15), rotation((0, 1, 0), 30), "Z"),
        (UsdPhysics.PrismaticJoint, "slider", link1, link2, (0.15, 0.35, 0.4), rotation((1, 0, 0), 60), "Y"),
        (UsdPhysics.RevoluteJoint, "wrist", link2, link3, (0.25, 0.4, 0.6), rotation((1, 0, 0), 180), "Z"),
    )
    for kind, name, parent, child, position, turn, axis in moving:
        joint(stage, kind, f"/World/arm/{name}", parent, child, tuple(c * u for c in position), turn, axis=axis)
    stage.Save()
    return stage


AXIS = {"X": Gf.Vec3d(1, 0, 0), "Y": Gf.Vec3d(0, 1, 0), "Z": Gf.Vec3d(0, 0, 1)}


def local_matrix(prim: Usd.Prim, index: str) -> Gf.Matrix4d:
    """A joint frame in body`index`'s local space, from localPos/localRot."""
    matrix = Gf.Matrix4d(1)
    matrix.SetRotateOnly(Gf.Quatd(prim.GetAttribute(f"physics:localRot{index}").Get()))
    matrix.SetTranslateOnly(Gf.Vec3d(prim.GetAttribute(f"physics:localPos{index}").Get()))
    return matrix


def expected_frames(stage: Usd.Stage, qpos: dict[str, float]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Anchor and axis of each joint in MuJoCo's world by forward kinematics in Gf (row vectors: a * b
    applies a first), moving each child body by its joint value from the stage's pose."""
    worlds: dict[str, Gf.Matrix4d] = {}
    frames = {}
    for name in ("shoulder", "slider", "wrist"):
        prim = stage.GetPrimAtPath(f"/World/arm/{name}")
        body0, body1 = (
            stage.GetPrimAtPath(t[0]) for t in (prim.GetRelationship(f"physics:body{i}").GetTargets() for i in "01")
        )
        parent = worlds.get(str(body0.GetPath()), world_matrix(body0))
        frame = local_matrix(prim, "0") * parent
        axis = AXIS[prim.GetAttribute("physics:axis").Get()]
        motion = Gf.Matrix4d(1)
        if prim.IsA(UsdPhysics.RevoluteJoint):
            motion.SetRotate(Gf.Rotation(axis, math.degrees(qpos[name])))
        else:
            motion.SetTranslate(axis * (qpos[name] / stage.GetMetadata("metersPerUnit")))
        worlds[str(body1.GetPath())] = local_matrix(prim, "1").GetInverse() * motion * frame
        anchor = to_mujoco(stage, frame.ExtractTranslation())
        direction = to_mujoco(stage, frame.ExtractRotation().TransformDir(axis), direction=True)
        frames[name] = anchor, direction
    return frames


@pytest.mark.parametrize(("up", "meters_per_unit"), [("Z", 1.0), ("Y", 0.01)], ids=["z-up-metres", "y-up-cm"])
def test_anchors_and_axes_match_the_stage_at_zero_and_random_poses(
    tmp_path: Path, up: str, meters_per_unit: float
) -> None:
    stage = arm(tmp_path / "arm.usda", up, meters_per_unit)
    model, data, warnings = compiled(tmp_path / "arm.usda")
    assert warnings == []
    assert [model.joint(i).name for i in range(model.njnt)] == ["shoulder", "slider", "wrist"]
    rng = np.random.default_rng(7)
    for qpos in (np.zeros(3), rng.uniform(-1.0, 1.0, 3) * [1, 0.1, 1]):
        data.qpos[:] = qpos
        mujoco.mj_forward(model, data)
        expected = expected_frames(stage, dict(zip(["shoulder", "slider", "wrist"], qpos, strict=True)))
        for index, name in enumerate(["shoulder", "slider", "wrist"]):
            np.testing.assert_allclose(data.xanchor[index], expected[name][0], atol=1e-6)
            np.testing.assert_allclose(data.xaxis[index], expected[name][1], atol=1e-6)
    data.qpos[:] = 0
    mujoco.mj_forward(model, data)
    assert data.xaxis[2] @ to_mujoco(stage, Gf.Vec3d(0, 0, -1), direction=True) == pytest.approx(1.0, abs=1e-6)


def test_bodies_keep_their_stage_pose_in_metres_and_z_up(tmp_path: Path) -> None:
    stage = arm(tmp_path / "arm.usda", "Y", 0.01)
    model, data, _ = compiled(tmp_path / "arm.usda")
    for name in ("base", "link1", "link2", "link3"):
        matrix = world_matrix(stage.GetPrimAtPath(f"/World/arm/{name}"))
        np.testing.assert_allclose(data.body(name).xpos, to_mujoco(stage, matrix.ExtractTranslation()), atol=1e-9)
        x_axis = to_mujoco(stage, matrix.ExtractRotation().TransformDir(Gf.Vec3d(1, 0, 0)), direction=True)
        np.testing.assert_allclose(data.body(name).xmat.reshape(3, 3)[:, 0], x_axis, atol=1e-6)  # float rotations
    np.testing.assert_allclose(data.geom("base/box").xpos, data.body("base").xpos)
    assert model.geom("base/box").size == pytest.approx([0.05] * 3)


def test_fixed_base_is_welded_and_a_jointless_root_floats(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "two.usda")
    fixed = body(stage, "/World/fixed", (0, 0, 1))
    joint(stage, UsdPhysics.FixedJoint, "/World/weld", None, fixed, (0, 0, 1))
    body(stage, "/World/floating", (1, 0, 1), rotation((0, 0, 1), 90))
    stage.Save()
    model, data, _ = compiled(tmp_path / "two.usda")
    assert model.body("fixed").jntnum == 0 and model.body("fixed").weldid == 0
    assert model.njnt == 1 and model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    assert model.jnt_bodyid[0] == model.body("floating").id
    np.testing.assert_allclose(data.qpos[:3], [1, 0, 1])
    mujoco.mj_step(model, data, 200)
    assert data.body("floating").xpos[2] < 0.5 and data.body("fixed").xpos[2] == pytest.approx(1)


def test_fixed_joint_welds_the_child_to_its_parent(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "weld.usda")
    base = body(stage, "/World/base", (0, 0, 1))
    tool = body(stage, "/World/tool", (0.3, 0, 1), rotation((0, 1, 0), 90))
    joint(stage, UsdPhysics.FixedJoint, "/World/mount", base, tool, (0.2, 0, 1), rotation((1, 0, 0), 10))
    stage.Save()
    model, data, warnings = compiled(tmp_path / "weld.usda")
    assert warnings == []
    assert model.body("tool").jntnum == 0 and model.body("tool").parentid == model.body("base").id
    mujoco.mj_step(model, data, 100)  # they fall together: the tool stays where it is on the base
    offset = data.body("tool").xpos - data.body("base").xpos
    np.testing.assert_allclose(offset, [0.3, 0, 0], atol=1e-9)
    assert data.body("base").xpos[2] < 0.95


def test_a_hinge_authored_away_from_zero_gets_that_value_as_ref(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "bent.usda")
    base = body(stage, "/World/base")
    link = body(stage, "/World/link", (0, 0, 0.5), rotation((0, 0, 1), 30))
    hinge = joint(stage, UsdPhysics.RevoluteJoint, "/World/hinge", base, link, (0, 0, 0.25), axis="Z")
    hinge.GetAttribute("physics:localRot1").Set(Gf.Quatf(1, 0, 0, 0))  # frame 1 = link's frame: 30 deg apart
    hinge.GetAttribute("physics:localPos1").Set(Gf.Vec3f(0, 0, -0.25))
    stage.Save()
    model, data, warnings = compiled(tmp_path / "bent.usda")
    assert warnings == []
    hinge_qpos = model.joint("hinge").qposadr[0]
    assert model.qpos0[hinge_qpos] == pytest.approx(math.radians(30))
    data.qpos[hinge_qpos] = 0
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.body("link").xmat.reshape(3, 3), np.eye(3), atol=1e-9)


def test_a_joint_whose_body0_is_the_child_is_reversed(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "reversed.usda")
    base = body(stage, "/World/base")
    link = body(stage, "/World/link", (0.4, 0, 0))
    joint(stage, UsdPhysics.FixedJoint, "/World/weld", None, base, (0, 0, 0))
    joint(stage, UsdPhysics.RevoluteJoint, "/World/hinge", link, base, (0.2, 0, 0), axis="Z")  # body0: child
    stage.Save()
    model, data, _ = compiled(tmp_path / "reversed.usda")
    assert model.body("link").parentid == model.body("base").id
    data.qpos[0] = 0.5
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.xanchor[0], [0.2, 0, 0], atol=1e-9)
    np.testing.assert_allclose(data.xaxis[0], [0, 0, -1], atol=1e-9)  # body1 (base) turns +q about +Z


def test_frames_that_disagree_are_warned_about_and_the_joint_wins(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "off.usda")
    base = body(stage, "/World/base")
    link = body(stage, "/World/link", (0, 0, 0.5))
    hinge = joint(stage, UsdPhysics.RevoluteJoint, "/World/hinge", base, link, (0, 0, 0.25), axis="X")
    hinge.GetAttribute("physics:localPos1").Set(Gf.Vec3f(0, 0.05, -0.25))
    stage.Save()
    model, data, warnings = compiled(tmp_path / "off.usda")
    assert len(warnings) == 1 and warnings[0].startswith("/World/hinge: ") and "0.05 m" in warnings[0]
    np.testing.assert_allclose(data.xanchor[model.joint("hinge").id], [0, 0, 0.25], atol=1e-9)
    np.testing.assert_allclose(data.body("link").xpos, [0, -0.05, 0.5], atol=1e-9)


def test_limits_in_degrees_and_stage_units_become_radians_and_metres(tmp_path: Path) -> None:
    stage = new_stage(tmp_path / "limits.usda", "Z", 0.01)
    base = body(stage, "/World/base", size=10)
    link1 = body(stage, "/World/link1", (0, 0, 50), size=10)
    link2 = body(stage, "/World/link2", (0, 0, 100), size=10)
    hinge = UsdPhysics.RevoluteJoint(joint(stage, UsdPhysics.RevoluteJoint, "/World/hinge", base, link1, (0, 0, 25)))
    hinge.CreateLowerLimitAttr(-120.0)
    hinge.CreateUpperLimitAttr(-30.0)
    slide = UsdPhysics.PrismaticJoint(joint(stage, UsdPhysics.PrismaticJoint, "/World/slide", link1, link2, (0, 0, 75)))
    slide.CreateLowerLimitAttr(-5.0)
    slide.CreateUpperLimitAttr(20.0)
    ball = joint(stage, UsdPhysics.SphericalJoint, "/World/ball", None, base, (0, 0, 0))
    UsdPhysics.SphericalJoint(ball).CreateConeAngle0LimitAttr(40.0)
    UsdPhysics.SphericalJoint(ball).CreateConeAngle1LimitAttr(30.0)
    stage.Save()
    model, _, warnings = compiled(tmp_path / "limits.usda")
    np.testing.assert_allclose(model.joint("hinge").range, np.radians([-120, -30]))
    np.testing.assert_allclose(model.joint("slide").range, [-0.05, 0.2])
    assert model.joint("ball").type == mujoco.mjtJoint.mjJNT_BALL
    np.testing.assert_allclose(model.joint("ball").range, [0, math.radians(40)])
    assert any(w.startswith("/World/ball: cone limits") for w in warnings)
