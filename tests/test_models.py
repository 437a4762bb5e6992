"""Tests for the robot models in models/: clean compilation, physical behaviour, MJX support,
required names, and reproducibility of the generated assets."""

from __future__ import annotations

import importlib.util
import warnings
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import mujoco
import numpy as np
import pytest

MODELS = Path(__file__).parents[1] / "models"
ARM_DIR = MODELS / "so_arm100"
SO101_DIR = MODELS / "so101"
ANT_XML = MODELS / "ant" / "ant.xml"
ANT_MJX_XML = MODELS / "ant" / "ant_mjx.xml"
TRILEG_XML = MODELS / "trileg" / "trileg.xml"
TRAJECTORY_CSV = MODELS / "trajectories" / "so_arm100_example.csv"

ALL_XML = sorted(MODELS.rglob("*.xml"))
ARM_VARIANTS = ["so_arm100.xml", "scene.xml", "scene_mjx.xml", "pick_place.xml", "pick_place_mjx.xml"]
# (model, tolerance of the MJX vs MuJoCo comparison after 100 steps).  MJX runs in float32 and
# its solver differs in detail; the Ant starts with its ankles outside their limits (as in
# Gymnasium), and that hard correction is where the two differ most.
MJX_CASES = [
    (ARM_DIR / "scene_mjx.xml", 1e-4),
    (ARM_DIR / "pick_place_mjx.xml", 1e-4),
    (ANT_XML, 1e-2),
    (ANT_MJX_XML, 1e-3),
]

ARM_JOINTS = [f"joint_{i}" for i in range(1, 7)]
SO101_JOINTS = ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper"]  # LeRobot's
# Each arm's folder, its joints, and the actuator driving a joint: the SO-ARM100's `<joint>_position`, the SO-101's
# named as its joint (LeRobot's motor names).
ARMS = {
    "so_arm100": (ARM_DIR, ARM_JOINTS, "{}_position"),
    "so101": (SO101_DIR, SO101_JOINTS, "{}"),
}


def arm_sensors(joints: list[str]) -> dict[str, mujoco.mjtSensor]:
    """The sensors every arm has: the wrist's force, torque and IMU, the jaw pads' touch, each joint's reading."""
    return {
        "wrist_force": mujoco.mjtSensor.mjSENS_FORCE,
        "wrist_torque": mujoco.mjtSensor.mjSENS_TORQUE,
        "wrist_accel": mujoco.mjtSensor.mjSENS_ACCELEROMETER,
        "wrist_gyro": mujoco.mjtSensor.mjSENS_GYRO,
        "gripper_touch_fixed": mujoco.mjtSensor.mjSENS_TOUCH,
        "gripper_touch_moving": mujoco.mjtSensor.mjSENS_TOUCH,
        **{f"{j}_pos": mujoco.mjtSensor.mjSENS_JOINTPOS for j in joints},
        **{f"{j}_vel": mujoco.mjtSensor.mjSENS_JOINTVEL for j in joints},
    }


def load(path: Path) -> mujoco.MjModel:
    """Compile an MJCF file."""
    return mujoco.MjModel.from_xml_path(str(path))


def reset_home(model: mujoco.MjModel) -> mujoco.MjData:
    """New data at the first keyframe (qpos and ctrl), or at qpos0 for models without one."""
    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    return data


def arm_qpos(model: mujoco.MjModel, data: mujoco.MjData, joints: list[str] = ARM_JOINTS) -> np.ndarray:
    """Positions of the arm's `joints` (the SO-ARM100's joint_1..joint_6 by default)."""
    return np.array([data.qpos[model.joint(name).qposadr[0]] for name in joints])


def import_script(path: Path) -> ModuleType:
    """Import a generator script that lives outside any package."""
    spec = importlib.util.spec_from_file_location(path.stem, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def mju_warnings() -> Iterator[list[str]]:
    """Collect MuJoCo's runtime/compiler warnings (mju_warning) instead of printing them."""
    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    yield messages
    mujoco.set_mju_user_warning(previous)


@pytest.mark.parametrize("path", ALL_XML, ids=lambda p: str(p.relative_to(MODELS)))
def test_compiles_and_steps_without_warnings(path: Path, mju_warnings: list[str]) -> None:
    """Every model compiles with no compiler warning and runs 300 steps with no runtime warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # MjSpec.compile reports compiler warnings as UserWarning
        model = mujoco.MjSpec.from_file(str(path)).compile()
    data = reset_home(model)
    mujoco.mj_step(model, data, nstep=300)
    assert not mju_warnings
    assert not data.warning.number.any(), [mujoco.mjtWarning(i).name for i in np.flatnonzero(data.warning.number)]
    assert np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()


@pytest.mark.parametrize("arm", ARMS)
@pytest.mark.parametrize("name", ["scene.xml", "pick_place.xml"])
def test_arm_holds_home(name: str, arm: str) -> None:
    """Started at `home` with its ctrl, the arm drifts less than 1e-3 rad in every joint over 10 s."""
    folder, joints, _ = ARMS[arm]
    model = load(folder / name)
    data = reset_home(model)
    start = arm_qpos(model, data, joints)
    np.testing.assert_allclose(data.ctrl, model.key("home").ctrl)
    mujoco.mj_step(model, data, nstep=round(10.0 / model.opt.timestep))
    assert data.time == pytest.approx(10.0)
    assert np.abs(arm_qpos(model, data, joints) - start).max() < 1e-3


def settle(path: Path, seconds: float) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """Simulate a model from its initial state with zero controls (holding controls for servos)."""
    model = load(path)
    data = reset_home(model)
    mujoco.mj_step(model, data, nstep=round(seconds / model.opt.timestep))
    return model, data


def floor_contacts(model: mujoco.MjModel, data: mujoco.MjData) -> set[str]:
    """Names of the geoms touching the floor."""
    floor = model.geom("floor").id
    touching = set()
    for contact in data.contact[: data.ncon]:
        if floor in contact.geom:
            other = contact.geom[0] if contact.geom[1] == floor else contact.geom[1]
            touching.add(model.geom(other).name)
    return touching


def test_ant_comes_to_rest_standing() -> None:
    """With zero controls the Ant falls from z = 0.75, lands on its legs and rests upright."""
    model, data = settle(ANT_XML, 4.0)
    torso = data.body("torso")
    assert 0.3 < torso.xpos[2] < 0.7  # landed, well inside Gymnasium's healthy range 0.2..1.0
    assert torso.xmat[8] > 0.95  # torso z-axis still points up
    assert np.abs(data.qvel).max() < 0.05
    touching = floor_contacts(model, data)
    assert "torso" not in touching
    assert {f"shin_{i}_geom" for i in range(1, 5)} <= touching


def test_ant_mjx_stands_on_its_feet_from_its_keyframe() -> None:
    """ant_mjx.xml's 'standing' keyframe stands where it starts (with zero torque the ankles only
    give way slowly); only the four feet touch the floor, and the feet are massless, so the Ant
    weighs what ant.xml's does."""
    model, data = settle(ANT_MJX_XML, 3.0)
    assert model.key("standing").id == 0
    torso = data.body("torso")
    assert torso.xpos[2] == pytest.approx(0.55, abs=0.01)
    assert torso.xmat[8] > 0.999
    assert np.abs(data.qvel).max() < 0.05
    assert floor_contacts(model, data) == {f"foot_{i}" for i in range(1, 5)}
    assert model.body_subtreemass[0] == pytest.approx(load(ANT_XML).body_subtreemass[0])


def test_ant_mjx_is_generated_from_ant_xml() -> None:
    """The committed ant_mjx.xml is exactly what make_mjx_variant.py makes of ant.xml."""
    generator = import_script(MODELS / "ant" / "make_mjx_variant.py")
    assert generator.variant(ANT_XML.read_text()) == ANT_MJX_XML.read_text()


def test_trileg_comes_to_rest_standing() -> None:
    """Holding ctrl = 0, the trileg drops onto its three feet and comes to rest upright."""
    model, data = settle(TRILEG_XML, 4.0)
    torso = data.body("torso")
    assert 0.18 < torso.xpos[2] < 0.22
    assert torso.xmat[8] > 0.99
    assert np.abs(data.qvel).max() < 1e-2
    assert floor_contacts(model, data) == {"foot_1", "foot_2", "foot_3"}


@pytest.mark.parametrize(("path", "atol"), MJX_CASES, ids=[path.name for path, _ in MJX_CASES])
@pytest.mark.slow
def test_mjx_steps_without_nan(path: Path, atol: float) -> None:
    """The MJX variants load with mjx.put_model; 100 jitted steps stay finite and close to MuJoCo's."""
    mjx = pytest.importorskip("mujoco.mjx")
    import jax

    model = load(path)
    data = reset_home(model)
    mjx_model = mjx.put_model(model)
    mjx_data = mjx.put_data(model, data)
    # XLA CPU optimisation level 1 compiles mjx.step sooner than the default (3), and compiling dominates this
    # file's run time; the stepping itself is not slower.
    step = jax.jit(mjx.step).lower(mjx_model, mjx_data).compile({"xla_backend_optimization_level": 1})
    for _ in range(100):
        mjx_data = step(mjx_model, mjx_data)
    qpos, qvel = np.asarray(mjx_data.qpos), np.asarray(mjx_data.qvel)
    assert np.isfinite(qpos).all() and np.isfinite(qvel).all()

    mujoco.mj_step(model, data, nstep=100)
    np.testing.assert_allclose(qpos, data.qpos, atol=atol)


@pytest.mark.parametrize("arm", ARMS)
@pytest.mark.parametrize("name", ARM_VARIANTS)
def test_arm_names(name: str, arm: str) -> None:
    """Every variant of each arm exposes the same joints, actuators, sensors, sites and home keyframe."""
    folder, joints, actuator_name = ARMS[arm]
    model = load(folder / name.replace("so_arm100.xml", f"{arm}.xml"))
    assert model.nu == len(joints)
    for joint in joints:
        assert model.joint(joint).type[0] == mujoco.mjtJoint.mjJNT_HINGE
        actuator = model.actuator(actuator_name.format(joint))
        assert actuator.trnid[0] == model.joint(joint).id
        assert actuator.biastype[0] == mujoco.mjtBias.mjBIAS_AFFINE  # position servo
        np.testing.assert_allclose(actuator.ctrlrange, model.joint(joint).range, atol=1e-12)
        assert 2.5 < actuator.forcerange[1] < 3.5  # STS3215 stall torque, ~3 N*m
    for sensor, kind in arm_sensors(joints).items():
        assert model.sensor(sensor).type[0] == kind
    model.site("gripper")
    model.site("wrist")
    home = model.key("home")
    assert np.all(home.ctrl >= model.actuator_ctrlrange[:, 0]) and np.all(home.ctrl <= model.actuator_ctrlrange[:, 1])


@pytest.mark.parametrize("arm", ARMS)
@pytest.mark.parametrize("name", ["scene.xml", "scene_mjx.xml", "pick_place.xml", "pick_place_mjx.xml"])
def test_scene_names(name: str, arm: str) -> None:
    """Scenes have the two cameras; pick-and-place scenes also have the free cube and the goal."""
    model = load(ARMS[arm][0] / name)
    model.camera("overview")
    model.camera("side")
    if name.startswith("pick_place"):
        assert model.joint("cube_joint").type[0] == mujoco.mjtJoint.mjJNT_FREE
        assert model.joint("cube_joint").bodyid[0] == model.body("cube").id
        model.site("goal")


@pytest.mark.parametrize("arm", ARMS)
def test_cameras_see_the_arm(arm: str) -> None:
    """Both scene cameras have the gripper and the base inside their field of view."""
    model = load(ARMS[arm][0] / "scene.xml")
    data = reset_home(model)
    for camera in ("overview", "side"):
        cam = data.camera(camera)
        fovy = np.deg2rad(model.camera(camera).fovy[0])
        for point in (data.site("gripper").xpos, data.body("base").xpos):
            local = cam.xmat.reshape(3, 3).T @ (point - cam.xpos)
            assert local[2] < 0  # in front of the camera (it looks along -z)
            assert abs(local[1] / local[2]) < np.tan(fovy / 2)


@pytest.mark.parametrize("arm", ARMS)
def test_links_excluded_from_the_table_stay_above_it(arm: str) -> None:
    """pick_place_mjx.xml excludes the world's contacts with the shoulder and the upper arm: over shoulder_lift's
    range, every collision geom of both lies above the table (z = 0), its bounding sphere included."""
    folder, joints, _ = ARMS[arm]
    model = load(folder / "pick_place_mjx.xml")
    data = mujoco.MjData(model)
    lift = model.joint(joints[1])
    links = {model.body("shoulder").id, model.body("upper_arm").id}
    geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] in links and model.geom_contype[g]]
    for angle in np.linspace(*lift.range, 25):
        data.qpos[lift.qposadr[0]] = angle
        mujoco.mj_kinematics(model, data)
        assert min(data.geom_xpos[g][2] - model.geom_rbound[g] for g in geoms) > 0, angle


def test_so101_zero_pose_is_lerobots_calibrated_zero() -> None:
    """At zero the SO-101 stands as LeRobot's calibration leaves 0 degrees (the middle of every range): upper arm
    up, forearm and gripper level and forward; positive lift, elbow and wrist flex tilt their link forward and
    down, and a positive gripper opens the jaw."""
    model = load(SO101_DIR / "so101.xml")
    data = mujoco.MjData(model)
    for joint in SO101_JOINTS[:4]:
        low, high = model.joint(joint).range
        assert low == pytest.approx(-high)  # LeRobot's 0 degrees: the middle of the calibrated range

    def positions(**angles: float) -> dict[str, np.ndarray]:
        data.qpos[:] = [angles.get(joint, 0.0) for joint in SO101_JOINTS]
        mujoco.mj_kinematics(model, data)
        bodies = ("upper_arm", "lower_arm", "wrist", "gripper")
        return {**{body: data.body(body).xpos.copy() for body in bodies}, "tip": data.site("gripper").xpos.copy()}

    zero = positions()
    upper, forearm = zero["lower_arm"] - zero["upper_arm"], zero["wrist"] - zero["lower_arm"]
    assert upper[2] > 0.1 and abs(upper[0]) < 0.03  # up, the SO-10x's 28 mm forward offset
    assert forearm[0] > 0.13 and abs(forearm[2]) < 0.01
    assert zero["tip"][0] > zero["gripper"][0] and abs(zero["tip"][2] - zero["gripper"][2]) < 0.015
    for joint, link in (("shoulder_lift", "lower_arm"), ("elbow_flex", "wrist"), ("wrist_flex", "tip")):
        moved = positions(**{joint: 0.3})[link]
        assert moved[2] < zero[link][2], joint  # forward and down
    data.qpos[:] = 0
    gap = []
    for jaw in (-0.17, 0.8):
        data.qpos[model.joint("gripper").qposadr[0]] = jaw
        mujoco.mj_kinematics(model, data)
        gap.append(np.linalg.norm(data.geom("moving_pad").xpos - data.geom("fixed_pad").xpos))
    assert gap[0] < 0.01 < 0.04 < gap[1]  # closed: the pads meet; open: a 3 cm cube fits between


def test_the_so101_mjx_scenes_load_on_mjx() -> None:
    """MJX takes the SO-101's MJX scenes as they are (put_model rejects geoms and options it does not support)."""
    mjx = pytest.importorskip("mujoco.mjx")
    for name in ("scene_mjx.xml", "pick_place_mjx.xml"):
        mjx.put_model(load(SO101_DIR / name))


def test_ant_and_trileg_names() -> None:
    """The Ant has the standard joints and gear-150 motors; the trileg has hips, knees and servos."""
    ant = load(ANT_XML)
    ant.body("torso")
    assert ant.joint("root").type[0] == mujoco.mjtJoint.mjJNT_FREE
    for i in range(1, 5):
        for joint in (f"hip_{i}", f"ankle_{i}"):
            assert ant.joint(joint).type[0] == mujoco.mjtJoint.mjJNT_HINGE
            assert ant.actuator(joint).trnid[0] == ant.joint(joint).id
    assert ant.nu == 8
    np.testing.assert_array_equal(ant.actuator_gear[:, 0], 150)
    np.testing.assert_array_equal(ant.actuator_ctrlrange, [[-1, 1]] * 8)
    assert ant.opt.timestep == 0.01

    trileg = load(TRILEG_XML)
    trileg.body("torso")
    for i in range(1, 4):
        for joint in (f"hip_{i}", f"knee_{i}"):
            assert trileg.actuator(f"{joint}_position").trnid[0] == trileg.joint(joint).id
    assert trileg.nu == 6


def test_meshes_match_generator(tmp_path: Path) -> None:
    """The committed STL files are exactly what generate_meshes.py produces, small and binary."""
    generator = import_script(ARM_DIR / "generate_meshes.py")
    generated = {path.name: path.read_bytes() for path in generator.generate(tmp_path)}
    committed = {path.name: path.read_bytes() for path in (ARM_DIR / "assets").glob("*.stl")}
    assert committed.keys() == generated.keys()
    for name, content in committed.items():
        assert content == generated[name], f"{name} differs from generate_meshes.py output"
        assert len(content) < 200_000
        n_triangles = int.from_bytes(content[80:84], "little")
        assert len(content) == 84 + 50 * n_triangles  # binary STL layout


def read_trajectory() -> tuple[list[str], list[str], np.ndarray]:
    """Split the example CSV into comment lines, header fields and the numeric rows."""
    lines = TRAJECTORY_CSV.read_text().splitlines()
    n_comments = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    header = lines[n_comments].split(",")
    rows = np.array([[float(v) for v in line.split(",")] for line in lines[n_comments + 1 :]])
    return lines[:n_comments], header, rows


def test_trajectory_csv() -> None:
    """The example trajectory is >= 5 s at 500 Hz, monotonic, and strictly inside the joint limits."""
    comments, header, rows = read_trajectory()
    assert any(c.startswith("# Format: timestamp, joint_1") for c in comments)
    assert any(c.startswith("# Units: seconds, radians") for c in comments)
    assert header == ["timestamp", *ARM_JOINTS]
    assert rows.shape[1] == 7
    times, positions = rows[:, 0], rows[:, 1:]
    assert times[0] == 0.0 and times[-1] >= 5.0
    np.testing.assert_allclose(np.diff(times), 0.002, atol=1e-9)
    assert np.all(np.diff(times) > 0)
    model = load(ARM_DIR / "so_arm100.xml")
    lo, hi = model.jnt_range.T
    assert np.all(positions > lo) and np.all(positions < hi)
    assert np.abs(np.diff(positions, axis=0)).max() < 0.01  # smooth: < 5 rad/s at 500 Hz


def test_trajectory_lifts_cube() -> None:
    """Replaying the example trajectory as servo targets in pick_place.xml grasps and lifts the cube."""
    _, _, rows = read_trajectory()
    model = load(ARM_DIR / "pick_place.xml")
    data = reset_home(model)
    # the trajectory is sampled every 2 ms, the scene steps 10 ms: each step gets the targets of its start time
    times = rows[:, 0]
    for time in np.arange(0.0, times[-1], model.opt.timestep):
        data.ctrl[:] = rows[np.searchsorted(times, time - 1e-9), 1:]
        mujoco.mj_step(model, data)
    assert data.body("cube").xpos[2] > 0.08
    assert data.sensor("gripper_touch_fixed").data[0] > 1.0
    assert data.sensor("gripper_touch_moving").data[0] > 1.0
