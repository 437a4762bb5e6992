"""Cameras (UsdGeom.Camera) and site sensors (documented prims with joshua:sensor:* attributes), with Isaac Sim's
own sensor prims beside them: an IsaacImuSensor where a site carries an accelerometer or gyro, and touch sensors as
IsaacContactSensor prims in bodies with PhysxContactReportAPI (Isaac's sensor schema; usd-core lacks it, so the
types and attributes are written by name)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

from joshua_usd.exporter.context import Context, set_physx, set_pose, set_raw
from joshua_usd.exporter.frames import gf_vec3f

HORIZONTAL_APERTURE = 20.955  # USD's default (mm); the focal length is chosen to give MuJoCo's fovy
CONTACT_SENSORS = {"touch"}  # their bodies get PhysxContactReportAPI, which Isaac's contact sensors need
IMU_SENSORS = {"accelerometer", "gyro"}  # what one Isaac IMU prim at their site measures
CONTACT_THRESHOLD = Gf.Vec2f(0, 100000)  # N: Isaac's default force range of a contact sensor


def write_cameras(ctx: Context) -> None:
    """A camera per MuJoCo camera, a child of its body (both look along -z with +y up). MuJoCo's fovy
    is vertical: with horizontal aperture A and the offscreen aspect w/h, verticalAperture = A*h/w
    and focalLength = verticalAperture / (2 tan(fovy/2)). Tracking modes become joshua:camera:mode."""
    model = ctx.model
    aspect = model.vis.global_.offwidth / model.vis.global_.offheight
    for cam in range(model.ncam):
        body = int(model.cam_bodyid[cam])
        path = ctx.child_path(ctx.parent_path(body), ctx.name(mujoco.mjtObj.mjOBJ_CAMERA, cam, "camera"))
        camera = UsdGeom.Camera.Define(ctx.stage, path)
        set_pose(camera.GetPrim(), model.cam_pos[cam], model.cam_quat[cam])
        vertical = HORIZONTAL_APERTURE / aspect
        camera.CreateHorizontalApertureAttr(HORIZONTAL_APERTURE)
        camera.CreateVerticalApertureAttr(float(vertical))
        camera.CreateFocalLengthAttr(float(vertical / (2 * math.tan(math.radians(model.cam_fovy[cam]) / 2))))
        extent = model.stat.extent
        clipping = Gf.Vec2f(float(model.vis.map.znear * extent), float(model.vis.map.zfar * extent))
        camera.CreateClippingRangeAttr(clipping)
        mode = mujoco.mjtCamLight(model.cam_mode[cam]).name[len("mjCAMLIGHT_") :].lower()
        if mode != "fixed":
            set_raw(camera.GetPrim(), "joshua:camera:mode", Sdf.ValueTypeNames.Token, mode, custom=True)


def write_sensors(ctx: Context) -> None:
    """An Xform per sensor at a site, at the site's pose in its body, with joshua:sensor:type (MuJoCo's
    type: accelerometer, gyro, force, torque, touch, ...), joshua:sensor:site, noise and cutoff where
    set, and for touch the site's zone (joshua:sensor:zoneType, joshua:sensor:zoneSize). Sensors of
    joints, actuators and other objects are notes: Isaac reads joint states itself."""
    model = ctx.model
    groups: dict[int, Sdf.Path] = {}
    imus: dict[int, list[str]] = {}
    for sensor in range(model.nsensor):
        name = ctx.name(mujoco.mjtObj.mjOBJ_SENSOR, sensor, "sensor")
        kind = mujoco.mjtSensor(model.sensor_type[sensor]).name[len("mjSENS_") :].lower()
        if model.sensor_objtype[sensor] != mujoco.mjtObj.mjOBJ_SITE:
            ctx.note(f"sensor '{name}': {kind} sensors are not exported (only sensors at sites)")
            continue
        site = int(model.sensor_objid[sensor])
        body = int(model.site_bodyid[site])
        if body not in groups:
            groups[body] = ctx.child_path(ctx.parent_path(body), "sensors")
            UsdGeom.Xform.Define(ctx.stage, groups[body])
        if kind in IMU_SENSORS:
            imus.setdefault(site, []).append(name)
        prim_type = "IsaacContactSensor" if kind in CONTACT_SENSORS and body else "Xform"
        prim = ctx.stage.DefinePrim(ctx.child_path(groups[body], name), prim_type)
        set_pose(prim, model.site_pos[site], model.site_quat[site])
        set_raw(prim, "joshua:sensor:type", Sdf.ValueTypeNames.Token, kind, custom=True)
        site_name = ctx.name(mujoco.mjtObj.mjOBJ_SITE, site, "site")
        set_raw(prim, "joshua:sensor:site", Sdf.ValueTypeNames.String, site_name, custom=True)
        for field in ("noise", "cutoff"):
            value = float(getattr(model, f"sensor_{field}")[sensor])
            if value > 0:
                set_raw(prim, f"joshua:sensor:{field}", Sdf.ValueTypeNames.Float, value, custom=True)
        if kind in CONTACT_SENSORS:
            zone = mujoco.mjtGeom(model.site_type[site]).name[len("mjGEOM_") :].lower()
            set_raw(prim, "joshua:sensor:zoneType", Sdf.ValueTypeNames.Token, zone, custom=True)
            size = gf_vec3f(model.site_size[site])
            set_raw(prim, "joshua:sensor:zoneSize", Sdf.ValueTypeNames.Float3, size, custom=True)
            if body:
                _contact_sensor(ctx, prim, body, float(np.linalg.norm(model.site_size[site])))
    for site, names in imus.items():
        _imu(ctx, groups[int(model.site_bodyid[site])], site, names)


def _contact_sensor(ctx: Context, prim: Usd.Prim, body: int, radius: float) -> None:
    """Isaac's contact sensor attributes on a touch sensor prim (its radius the bounding sphere of the site's
    zone) and PhysxContactReportAPI, reporting every contact, on its body."""
    set_raw(prim, "enabled", Sdf.ValueTypeNames.Bool, True)
    set_raw(prim, "threshold", Sdf.ValueTypeNames.Float2, CONTACT_THRESHOLD)
    set_raw(prim, "radius", Sdf.ValueTypeNames.Float, radius)
    body_prim = ctx.stage.GetPrimAtPath(ctx.body_paths[body])
    set_physx(body_prim, "PhysxContactReportAPI", "threshold", Sdf.ValueTypeNames.Float, 0.0)


def _imu(ctx: Context, group: Sdf.Path, site: int, names: list[str]) -> None:
    """One IsaacImuSensor at a site with accelerometers or gyros, naming them in joshua:sensor:imuOf (the importer
    reads those sensors from their own prims); filter widths 1: raw readings, as MuJoCo's."""
    model = ctx.model
    site_name = ctx.name(mujoco.mjtObj.mjOBJ_SITE, site, "site")
    prim_name = site_name if "imu" in site_name.lower() else f"{site_name}_imu"
    prim = ctx.stage.DefinePrim(ctx.child_path(group, prim_name), "IsaacImuSensor")
    set_pose(prim, model.site_pos[site], model.site_quat[site])
    set_raw(prim, "enabled", Sdf.ValueTypeNames.Bool, True)
    for width in ("linearAcceleration", "angularVelocity", "orientation"):
        set_raw(prim, f"{width}FilterWidth", Sdf.ValueTypeNames.Int, 1)
    set_raw(prim, "joshua:sensor:site", Sdf.ValueTypeNames.String, site_name, custom=True)
    set_raw(prim, "joshua:sensor:imuOf", Sdf.ValueTypeNames.StringArray, Vt.StringArray(names), custom=True)
