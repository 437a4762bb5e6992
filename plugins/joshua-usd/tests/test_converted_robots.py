"""MJCF robots converted to USD by NVIDIA/Newton's mujoco-usd-converter, as a user converts them, loaded through
joshua-usd's reader and run beside their MJCF under the same controls: the same joint trajectories for 500 steps.

The converter runs in its own environment, .cache/usd-converter (`./setup.sh --dev`, tests/converter-requirements.txt):
it needs mujoco<3.17 and a `pxr` of its own. Every run converts afresh into a temporary folder.

The robots: SO-ARM100 (meshes, armature, friction loss, implicitfast, elliptic cones), Ant (free base, contacts,
armature), trileg (position servos) and geared_arm below (armature and friction loss on a hinge, a slide and a ball
joint, a joint spring, non-zero references, RK4 at 1 kHz: a time step the converter leaves to NewtonSceneAPI's
fallback). The converter writes no contype/conaffinity (its own "FUTURE: collision filtering"), so colliders that
the MJCF keeps apart touch in the USD: trileg runs at half its control range, where no foot reaches the torso."""

from __future__ import annotations

import subprocess
from pathlib import Path

import mujoco
import numpy as np
import pytest

from joshua_core.resources import models_dir
from joshua_usd.inspect import describe
from joshua_usd.reader import UsdReader

REPO = Path(__file__).resolve().parents[3]
CONVERTER = REPO / ".cache" / "usd-converter" / "bin" / "mujoco_usd_converter"
STEPS = 500
SEGMENT = 50  # steps per control value: piecewise-constant random controls
# Largest difference, over the 500 steps, of a hinge or slide (rad or m), a free body's position (m) or a ball's or
# free body's orientation (rad): USD's float attributes (7 digits) against the MJCF's doubles, amplified by contacts.
TOLERANCE = 1e-3
GEARED_ARM = """<mujoco model="geared_arm">
  <compiler angle="degree"/>
  <option timestep="0.001" integrator="RK4"/>
  <default>
    <joint armature="0.05" frictionloss="0.3" damping="0.2"/>
    <geom type="capsule" size="0.03" density="800"/>
  </default>
  <worldbody>
    <body name="base" pos="0 0 1">
      <geom name="base" type="box" size="0.05 0.05 0.05"/>
      <body name="upper" pos="0 0 -0.1">
        <joint name="shoulder" axis="0 1 0" range="-100 100" ref="20" stiffness="2" springref="10"
               solreflimit="0.01 1"/>
        <geom name="upper" fromto="0 0 0 0.3 0 0"/>
        <body name="lower" pos="0.3 0 0">
          <joint name="elbow" axis="0 1 0" range="-45 120" armature="0.02" frictionloss="0.1"/>
          <geom name="lower" fromto="0 0 0 0.25 0 0"/>
          <body name="slider" pos="0.25 0 0">
            <joint name="extend" type="slide" axis="1 0 0" range="0 0.1" ref="0.02" armature="0.5" frictionloss="2"/>
            <geom name="slider" fromto="0 0 0 0.1 0 0" size="0.02"/>
            <body name="hand" pos="0.1 0 0">
              <joint name="wrist" type="ball" armature="0.01" frictionloss="0.02" damping="0.05"/>
              <geom name="hand" type="box" size="0.04 0.02 0.01" pos="0.04 0 0"/>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="shoulder" joint="shoulder" gear="10" ctrlrange="-1 1"/>
    <motor name="elbow" joint="elbow" gear="5" ctrlrange="-1 1"/>
    <position name="extend" joint="extend" kp="200" kv="5" ctrlrange="0 0.1"/>
  </actuator>
</mujoco>
"""
# name: (MJCF under models/, or None for GEARED_ARM; the controls' amplitude as a fraction of half the range)
ROBOTS = {
    "so_arm100": ("so_arm100/so_arm100.xml", 1.0),
    "ant": ("ant/ant.xml", 1.0),
    "trileg": ("trileg/trileg.xml", 0.5),
    "geared_arm": (None, 1.0),
}


@pytest.fixture(scope="module")
def converted(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, Path]]:
    """Each robot's MJCF and the USD the converter writes from it (all converted side by side)."""
    if not CONVERTER.is_file():
        pytest.fail(f"mujoco-usd-converter is not installed in {CONVERTER.parents[1]}: run ./setup.sh --dev")
    folder = tmp_path_factory.mktemp("converted")
    (folder / "geared_arm.xml").write_text(GEARED_ARM)
    sources = {name: models_dir() / xml if xml else folder / f"{name}.xml" for name, (xml, _) in ROBOTS.items()}
    runs = {
        name: subprocess.Popen(
            [str(CONVERTER), str(source), str(folder / name)],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        for name, source in sources.items()
    }
    for name, run in runs.items():
        output = run.communicate(timeout=120)[0]
        assert run.returncode == 0, f"{name}: {output[-3000:]}"
    return {name: (source, next((folder / name).glob("*.usda"))) for name, source in sources.items()}


def rollout(model: mujoco.MjModel, controls: np.ndarray, actuators: list[str]) -> np.ndarray:
    """qpos after each step under `controls` (one row per step, columns in the order of `actuators`, by name)."""
    data = mujoco.MjData(model)
    order = [model.actuator(name).id for name in actuators]
    trajectory = np.empty((len(controls), model.nq))
    for step, control in enumerate(controls):
        data.ctrl[order] = control
        mujoco.mj_step(model, data)
        trajectory[step] = data.qpos
    return trajectory


def deviation(source: mujoco.MjModel, a: np.ndarray, imported: mujoco.MjModel, b: np.ndarray) -> dict[str, float]:
    """Per joint of `source` (matched by name; an unnamed free joint by type), the largest difference over the
    trajectories `a` and `b`: position for hinges and slides, position and orientation angle for free joints,
    orientation angle for balls."""
    found = {}
    for index in range(source.njnt):
        joint = source.joint(index)
        kind = int(joint.type[0])
        match = mujoco.mj_name2id(imported, mujoco.mjtObj.mjOBJ_JOINT, joint.name)
        match = match if match >= 0 else int(np.flatnonzero(imported.jnt_type == kind)[0])
        width = {mujoco.mjtJoint.mjJNT_FREE: 7, mujoco.mjtJoint.mjJNT_BALL: 4}.get(kind, 1)
        x = a[:, joint.qposadr[0] : joint.qposadr[0] + width]
        y = b[:, imported.jnt_qposadr[match] : imported.jnt_qposadr[match] + width]
        if width == 1:
            found[joint.name] = float(np.abs(x - y).max())
            continue
        cosine = np.clip(np.abs((x[:, -4:] * y[:, -4:]).sum(axis=1)), 0.0, 1.0)
        found[joint.name or "free"] = float(
            max(2 * np.arccos(cosine).max(), np.abs(x[:, :-4] - y[:, :-4]).max(initial=0))
        )
    return found


@pytest.mark.parametrize("name", ROBOTS)
def test_converted_robot_follows_its_mjcf(converted: dict[str, tuple[Path, Path]], name: str) -> None:
    mjcf, usd = converted[name]
    source = mujoco.MjModel.from_xml_path(str(mjcf))
    imported = UsdReader().read(usd).compile()
    assert imported.opt.timestep == pytest.approx(source.opt.timestep)
    actuators = [source.actuator(index).name for index in range(source.nu)]
    low, high = source.actuator_ctrlrange.T
    middle, half = (low + high) / 2, (high - low) / 2 * ROBOTS[name][1]
    segments = np.random.default_rng(0).uniform(middle - half, middle + half, size=(STEPS // SEGMENT, source.nu))
    controls = np.repeat(segments, SEGMENT, axis=0)
    found = deviation(source, rollout(source, controls, actuators), imported, rollout(imported, controls, actuators))
    assert max(found.values()) < TOLERANCE, found


def test_inspect_shows_the_converted_joints_and_what_it_did_not_use(converted: dict[str, tuple[Path, Path]]) -> None:
    text = describe(converted["geared_arm"][1])
    assert "timestep 0.001 s, gravity (0, 0, -9.81) m/s^2, solver iterations 100, integrator rk4" in text
    assert "armature 0.05 kg m^2, damping 0.2 N m s/rad, frictionloss 0.3 N m" in text  # the shoulder
    assert "armature 0.5 kg, damping 0.2 N s/m, frictionloss 2 N" in text  # the slide
    unused = text.split("physics attributes not used (")[1].split("warnings")[0]
    assert unused.startswith("3):\n"), unused
    for line in (
        "/geared_arm/Geometry/base: newton:jointsAddMobility = True",  # no stacked joints here
        "/geared_arm/Physics/PhysicsMaterial: newton:contactDamping = 100",  # contacts come from mjc:solref
        "/geared_arm/Physics/PhysicsMaterial: newton:contactStiffness = 2500",
    ):
        assert f"  {line}\n" in unused
