"""Cameras (UsdGeom.Camera) and site sensors (documented Xforms with joshua:sensor:* attributes)."""

from __future__ import annotations

import math

import mujoco
from pxr import Gf, Sdf, UsdGeom

from joshua_usd.exporter.context import Context, set_pose, set_raw
from joshua_usd.exporter.frames import gf_vec3f

HORIZONTAL_APERTURE = 20.955  # USD's default (mm); the focal length is chosen to give MuJoCo's fovy
CONTACT_SENSORS = {"touch"}  # their bodies get PhysxContactReportAPI, which Isaac's contact sensors need


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
        prim = UsdGeom.Xform.Define(ctx.stage, ctx.child_path(groups[body], name)).GetPrim()
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
                ctx.stage.GetPrimAtPath(ctx.body_paths[body]).AddAppliedSchema("PhysxContactReportAPI")
