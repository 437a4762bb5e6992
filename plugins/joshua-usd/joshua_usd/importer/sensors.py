"""Cameras (UsdGeom.Camera) as MuJoCo cameras, and sensors as sites with MuJoCo sensors: the exporter's documented
prims (joshua:sensor:type, :site, :noise, :cutoff, a touch zone), Isaac Sim's IMU prims (IsaacImuSensor: an
accelerometer and a gyro) and contact sensor prims (IsaacContactSensor: a touch sensor over its radius, or the
body's colliders where the radius is negative, Isaac's "use the collision geometry")."""

from __future__ import annotations

import math
from collections.abc import Callable

import mujoco
import numpy as np
from pxr import Sdf, Usd, UsdGeom

from joshua_usd.importer.pose import Pose, Vec
from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.stage import StageFrame, prims, read, read_physx
from joshua_usd.importer.topology import enclosing_body
from joshua_usd.physx_schema import attribute_name

IMU_TYPE = "IsaacImuSensor"
CONTACT_TYPE = "IsaacContactSensor"
IMU_SENSORS = (("accelerometer", "accel"), ("gyro", "gyro"))  # what an IMU measures, and the name suffix
IMU_OF = "joshua:sensor:imuOf"  # the exporter's IMU prim: the MuJoCo sensors it stands for (imported from theirs)
SITE_SHAPES = {"sphere", "capsule", "ellipsoid", "cylinder", "box"}

# A MuJoCo body and its stage pose: where sites and cameras of prims inside it are placed.
BodyOf = Callable[[Usd.Prim | None], tuple[mujoco.MjsBody, Pose]]


def add_cameras(stage: Usd.Stage, body_of: BodyOf, frame: StageFrame, report: ImportReport) -> None:
    """A MuJoCo camera per UsdGeom.Camera, in its rigid body (or the world): both look along -z with +y up;
    fovy = 2 atan(verticalAperture / (2 focalLength)); joshua:camera:mode restores a tracking mode."""
    for prim in prims(stage):
        if not prim.IsA(UsdGeom.Camera):
            continue
        body, pose = body_of(prim)
        in_body = pose.inverse() * frame.world_pose(prim)[0]
        aperture, focal = (read(prim, name, report) for name in ("verticalAperture", "focalLength"))
        camera = body.add_camera(name=prim.GetName(), pos=in_body.pos, quat=in_body.quat)
        if aperture and focal and aperture > 0 and focal > 0:
            camera.fovy = math.degrees(2 * math.atan(aperture / (2 * focal)))
        mode = read(prim, "joshua:camera:mode", report)
        if mode is not None:
            member = getattr(mujoco.mjtCamLight, f"mjCAMLIGHT_{str(mode).upper()}", None)
            if member is None:
                report.warn(prim.GetPath(), f"joshua:camera:mode {mode!r} is not a MuJoCo camera mode: fixed")
            else:
                camera.mode = member


def add_sensors(
    spec: mujoco.MjSpec,
    stage: Usd.Stage,
    bodies: set[Sdf.Path],
    body_of: BodyOf,
    model: mujoco.MjModel,
    frame: StageFrame,
    report: ImportReport,
) -> None:
    """Sites and sensors of the exporter's sensor prims and of Isaac's IMU and contact sensor prims. `model`
    (compiled without them) gives the extent of a body's colliders for a contact sensor with no radius."""
    sites: dict[tuple[str, str], mujoco.MjsSite] = {}
    for prim in prims(stage):
        kind = read(prim, "joshua:sensor:type", report)
        is_imu, is_contact = prim.GetTypeName() == IMU_TYPE, prim.GetTypeName() == CONTACT_TYPE
        if kind is None and not is_contact and not (is_imu and not prim.HasAttribute(IMU_OF)):
            continue
        owner = enclosing_body(prim, bodies)
        if owner is None:
            report.warn(prim.GetPath(), "a sensor in no rigid body: not imported")
            continue
        if read(prim, "enabled", report) is False:
            report.warn(prim.GetPath(), "a disabled sensor: not imported")
            continue
        if is_contact:
            _report_threshold(owner, report)
        body, pose = body_of(prim)
        site_name = str(read(prim, "joshua:sensor:site", report) or prim.GetName())
        key = (body.name, site_name)
        if key not in sites:
            sites[key] = _site(body, prim, pose.inverse() * frame.world_pose(prim)[0], site_name, model, frame, report)
        site = sites[key]
        if kind is None and is_imu:
            for sensor_kind, suffix in IMU_SENSORS:
                _sensor(spec, prim, sensor_kind, f"{prim.GetName()}_{suffix}", site, report)
        else:
            _sensor(spec, prim, str(kind or "touch"), prim.GetName(), site, report)


def _report_threshold(body: Usd.Prim, report: ImportReport) -> None:
    """Warn about a positive PhysxContactReportAPI threshold on a contact sensor's body: MuJoCo's touch sensor reads
    every contact, as PhysX's threshold of 0 does."""
    threshold = read_physx(body, "PhysxContactReportAPI", "threshold", report)
    if threshold:
        message = f"contact report threshold {threshold:.6g}: MuJoCo's touch sensor reads every contact"
        report.warn(body.GetPath(), message)
        report.ignore(body.GetPath(), attribute_name("PhysxContactReportAPI", "threshold"))


def _site(
    body: mujoco.MjsBody,
    prim: Usd.Prim,
    in_body: Pose,
    name: str,
    model: mujoco.MjModel,
    frame: StageFrame,
    report: ImportReport,
) -> mujoco.MjsSite:
    """The site of a sensor prim: the exporter's touch zone where written, else a sphere of the contact
    sensor's radius, else (a negative radius) a sphere around the body's colliders."""
    site = body.add_site(name=name, pos=in_body.pos, quat=in_body.quat)
    zone, size = read(prim, "joshua:sensor:zoneType", report), read(prim, "joshua:sensor:zoneSize", report)
    if zone is not None and size is not None and str(zone) in SITE_SHAPES:
        site.type = getattr(mujoco.mjtGeom, f"mjGEOM_{str(zone).upper()}")
        site.size = np.asarray(size, dtype=np.float64)
    elif prim.GetTypeName() == CONTACT_TYPE:
        radius = read(prim, "radius", report)
        site.size[0] = radius * frame.meters_per_unit if radius and radius > 0 else _reach(model, body, in_body.pos)
    return site


def _reach(model: mujoco.MjModel, body: mujoco.MjsBody, centre: Vec) -> float:
    """The radius about `centre` (in the body) of a sphere holding every collider of the body."""
    index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body.name)
    geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == index and model.geom_contype[g]]
    reaches = [np.linalg.norm(model.geom_pos[g] - centre) + model.geom_rbound[g] for g in geoms]
    return float(max(reaches, default=0.0)) or 0.01


def _sensor(
    spec: mujoco.MjSpec, prim: Usd.Prim, kind: str, name: str, site: mujoco.MjsSite, report: ImportReport
) -> None:
    """A MuJoCo sensor of type `kind` (MuJoCo's name: touch, accelerometer, gyro, force, ...) at `site`."""
    member = getattr(mujoco.mjtSensor, f"mjSENS_{kind.upper()}", None)
    if member is None:
        report.warn(prim.GetPath(), f"joshua:sensor:type {kind!r} is not a MuJoCo site sensor: not imported")
        return
    sensor = spec.add_sensor(name=name, type=member, objtype=mujoco.mjtObj.mjOBJ_SITE, objname=site.name)
    for field in ("noise", "cutoff"):
        value = read(prim, f"joshua:sensor:{field}", report)
        if value:
            setattr(sensor, field, float(value))
