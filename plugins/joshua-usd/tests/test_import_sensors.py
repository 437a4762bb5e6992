"""Cameras and sensors read back into MuJoCo: the shipped SO-ARM100 and SO-101 (their scenes' cameras, touch
sensors on the gripper pads, the wrist IMU) and sensor prims as Isaac Sim authors them (IsaacImuSensor,
IsaacContactSensor under a body with PhysxContactReportAPI) with none of the exporter's attributes."""

from __future__ import annotations

import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom

sys.path.insert(0, str(Path(__file__).parent))

from usd_stages import body, new_stage  # noqa: E402

from joshua_core.resources import models_dir  # noqa: E402
from joshua_usd.importer import import_usd  # noqa: E402

SENSOR = mujoco.mjtSensor


@pytest.mark.parametrize(
    ("usd", "scene_path"), [("so100.usd", "so_arm100/scene.xml"), ("so101.usd", "so101/scene.xml")]
)
def test_the_shipped_arms_read_back_their_cameras_pads_and_imu(usd: str, scene_path: str) -> None:
    imported = import_usd(models_dir() / "isaac" / usd)
    model = imported.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    scene = mujoco.MjModel.from_xml_path(str(models_dir() / scene_path))
    scene_data = mujoco.MjData(scene)
    mujoco.mj_forward(scene, scene_data)
    assert sorted(model.camera(i).name for i in range(model.ncam)) == ["overview", "side"]
    for name in ("overview", "side"):
        assert model.camera(name).fovy[0] == pytest.approx(scene.camera(name).fovy[0], abs=1e-4)
        np.testing.assert_allclose(data.camera(name).xpos, scene_data.camera(name).xpos, atol=1e-9)
        np.testing.assert_allclose(data.camera(name).xmat, scene_data.camera(name).xmat, atol=1e-6)
    kinds = {model.sensor(i).name: int(model.sensor_type[i]) for i in range(model.nsensor)}
    assert kinds == {
        "wrist_force": SENSOR.mjSENS_FORCE,
        "wrist_torque": SENSOR.mjSENS_TORQUE,
        "wrist_accel": SENSOR.mjSENS_ACCELEROMETER,
        "wrist_gyro": SENSOR.mjSENS_GYRO,
        "gripper_touch_fixed": SENSOR.mjSENS_TOUCH,
        "gripper_touch_moving": SENSOR.mjSENS_TOUCH,
    }
    for site in ("wrist", "fixed_pad", "moving_pad"):
        np.testing.assert_allclose(data.site(site).xpos, scene_data.site(site).xpos, atol=1e-7)
    for pad in ("fixed_pad", "moving_pad"):
        assert model.site(pad).type[0] == mujoco.mjtGeom.mjGEOM_BOX
        np.testing.assert_allclose(model.site(pad).size, scene.site(pad).size, rtol=1e-6)
    assert model.site(model.sensor("wrist_gyro").objid[0]).name == "wrist"
    assert not imported.report.warnings


def isaac_sensors(path: Path, radius: float) -> None:
    """A 1 kg box resting on a static floor collider; an IsaacContactSensor of `radius` and an IsaacImuSensor
    under the box, PhysxContactReportAPI on it, all as Isaac writes them (types and attributes by name)."""
    stage = new_stage(path)
    floor = UsdGeom.Cube.Define(stage, "/World/floor")
    floor.CreateSizeAttr(1.0)
    floor.AddTranslateOp().Set(Gf.Vec3d(0, 0, -0.5))
    floor.GetPrim().AddAppliedSchema("PhysicsCollisionAPI")
    box = body(stage, "/World/box", (0, 0, 0.05), size=0.1)
    box.AddAppliedSchema("PhysxContactReportAPI")
    box.CreateAttribute("physxContactReport:threshold", Sdf.ValueTypeNames.Float).Set(0.0)
    contact = stage.DefinePrim("/World/box/Contact_Sensor", "IsaacContactSensor")
    UsdGeom.XformCommonAPI(contact)  # Isaac's sensors are Xformable: translate op below
    contact.CreateAttribute("xformOp:translate", Sdf.ValueTypeNames.Double3).Set(Gf.Vec3d(0, 0, -0.05))
    contact.CreateAttribute("xformOpOrder", Sdf.ValueTypeNames.TokenArray).Set(["xformOp:translate"])
    contact.CreateAttribute("radius", Sdf.ValueTypeNames.Float).Set(radius)
    contact.CreateAttribute("threshold", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0, 100000))
    contact.CreateAttribute("enabled", Sdf.ValueTypeNames.Bool).Set(True)
    imu = stage.DefinePrim("/World/box/Imu_Sensor", "IsaacImuSensor")
    imu.CreateAttribute("enabled", Sdf.ValueTypeNames.Bool).Set(True)
    imu.CreateAttribute("linearAccelerationFilterWidth", Sdf.ValueTypeNames.Int).Set(1)
    stage.Save()


@pytest.mark.parametrize("radius", [-1.0, 0.08])
def test_isaac_contact_and_imu_sensor_prims_become_touch_accelerometer_and_gyro(tmp_path: Path, radius: float) -> None:
    isaac_sensors(tmp_path / "box.usda", radius)
    imported = import_usd(tmp_path / "box.usda")
    model = imported.spec.compile()
    kinds = {model.sensor(i).name: int(model.sensor_type[i]) for i in range(model.nsensor)}
    assert kinds == {
        "Contact_Sensor": SENSOR.mjSENS_TOUCH,
        "Imu_Sensor_accel": SENSOR.mjSENS_ACCELEROMETER,
        "Imu_Sensor_gyro": SENSOR.mjSENS_GYRO,
    }
    contact_site = model.site("Contact_Sensor")
    np.testing.assert_allclose(contact_site.pos, [0, 0, -0.05], atol=1e-9)
    reach = 0.05 + 0.05 * np.sqrt(3)  # from the bottom face's centre: the box's centre, then its bounding sphere
    assert contact_site.size[0] == pytest.approx(0.08 if radius > 0 else reach, rel=1e-6)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=500)  # settles on the floor
    weight = model.body("box").mass[0] * 9.80665
    assert data.sensor("Contact_Sensor").data[0] == pytest.approx(weight, rel=0.05)
    np.testing.assert_allclose(data.sensor("Imu_Sensor_accel").data, [0, 0, 9.80665], atol=0.05)
    np.testing.assert_allclose(data.sensor("Imu_Sensor_gyro").data, [0, 0, 0], atol=1e-3)
    assert not imported.report.warnings
