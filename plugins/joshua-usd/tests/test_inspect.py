"""`joshua usd inspect FILE` and USD as a model_path: describe() text, the CLI's exit codes, the reader's
warnings on stderr, and a MuJoCoEngine loading and stepping a .usda file."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pxr import Sdf, UsdPhysics

sys.path.insert(0, str(Path(__file__).parent))

from usd_stages import body, joint, new_stage  # noqa: E402

from joshua_usd.inspect import describe  # noqa: E402


def robot(path: Path) -> Path:
    """A centimetre stage: a floating base with a limited, driven hinge (-45..90 deg) to an arm."""
    stage = new_stage(path, "Z", 0.01)
    base = body(stage, "/World/robot/base", (0, 0, 50), size=10)
    arm = body(stage, "/World/robot/arm", (20, 0, 50), size=10)
    elbow = joint(stage, UsdPhysics.RevoluteJoint, "/World/robot/elbow", base, arm, (10, 0, 50), axis="Y")
    hinge = UsdPhysics.RevoluteJoint(elbow)
    hinge.CreateLowerLimitAttr(-45.0)
    hinge.CreateUpperLimitAttr(90.0)
    drive = UsdPhysics.DriveAPI.Apply(hinge.GetPrim(), "angular")
    drive.CreateStiffnessAttr(1000.0)
    drive.CreateDampingAttr(10.0)
    hinge.GetPrim().CreateAttribute("physxJoint:maxJointVelocity", Sdf.ValueTypeNames.Float).Set(100.0)
    stage.Save()
    return path


def run_inspect(path: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "joshua_core.cli", "usd", "inspect", str(path)],
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_describe_lists_bodies_joints_in_radians_and_degrees_and_drives_in_si(tmp_path: Path) -> None:
    text = describe(robot(tmp_path / "robot.usda"))
    assert "upAxis Z" in text and "metersPerUnit 0.01" in text
    assert "base: mass 1 kg" in text and "floating" in text
    assert f"limits [{-math.pi / 4:.6g}, {math.pi / 2:.6g}] rad = [-45, 90] deg" in text
    per_degree_cm = 180 / math.pi * 1e-4  # N m/rad per (kg cm^2/s^2)/deg
    assert f"elbow: position, kp {1000 * per_degree_cm:.6g} N m/rad, kv {10 * per_degree_cm:.6g} N m s/rad" in text
    assert "colliders (2, plus 0 visual-only geoms)" in text
    assert "warnings (1):\n  /World/robot/elbow: physxJoint:maxJointVelocity 100 is not enforced" in text


def test_cli_inspect_prints_the_description_and_exits_0(tmp_path: Path) -> None:
    result = run_inspect(robot(tmp_path / "robot.usda"))
    assert result.returncode == 0, result.stderr
    assert "rad = [-45, 90] deg" in result.stdout and "elbow: revolute (hinge)" in result.stdout


def test_cli_inspect_of_a_broken_stage_exits_2_with_one_error_line(tmp_path: Path) -> None:
    path = robot(tmp_path / "robot.usda")
    path.write_text(path.read_text().replace("</World/robot/arm>", "</World/robot/missing>"))
    result = run_inspect(path)
    assert result.returncode == 2
    assert result.stderr.splitlines() == [
        f"joshua: error: {path}: /World/robot/elbow: physics:body1: target </World/robot/missing> does not exist"
    ]


def test_mujoco_engine_loads_and_steps_a_usd_model_path(tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    from joshua_mujoco import MuJoCoEngine

    engine = MuJoCoEngine(model_path=robot(tmp_path / "robot.usda"))
    warnings = capfd.readouterr().err.splitlines()
    assert [line for line in warnings if line.startswith("joshua: warning:")] == [
        f"joshua: warning: {tmp_path / 'robot.usda'}: /World/robot/elbow: physxJoint:maxJointVelocity 100 is not "
        "enforced by MuJoCo"
    ]
    start = engine.get_qpos()
    engine.set_ctrl([0.5])
    engine.step(500)
    assert engine.time == pytest.approx(500 * engine.timestep)
    assert engine.get_qpos()[2] < start[2] - 0.1  # the floating base falls
    assert engine.instability() is None and np.isfinite(engine.get_qpos()).all()


def test_the_shipped_so100_describes_its_joint_physics_and_solver_without_warnings() -> None:
    from joshua_core.resources import models_dir

    text = describe(models_dir() / "isaac" / "so100.usd")
    assert "integrator implicitfast, cone elliptic, impratio 10" in text
    assert "armature 0.028 kg m^2, damping 0.6 N m s/rad, frictionloss 0.052 N m" in text
    assert "joint_1_position: position, kp 17.8 N m/rad, kv 0 N m s/rad, ctrl range (-1.92, 1.92)" in text
    assert text.endswith("warnings (0):")


def test_cli_inspect_of_a_missing_file_names_it_once(tmp_path: Path) -> None:
    result = run_inspect(tmp_path / "nowhere.usda")
    assert result.returncode == 2
    assert result.stderr.startswith(f"joshua: error: USD file '{tmp_path / 'nowhere.usda'}' not found")
