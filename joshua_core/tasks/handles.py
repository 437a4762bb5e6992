"""Model handles: term parameters that name model objects, resolved to indices when a task is built.

A term declares such a parameter by its annotation, e.g. `def site_pos(ctx, site: Site)`. Configs
and task specs give the name (`site="gripper"`); `resolve_handle` turns it into the handle, so
the kernel indexes arrays with plain integers (static under `jax.jit`) and a wrong name fails
at build time with the names the model has. The model is a `mujoco.MjModel` (used duck-typed:
the core does not import mujoco).
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

# MuJoCo joint types (mjtJoint) and how many qpos / qvel entries each has.
_FREE, _BALL = 0, 1
_JOINT_SIZES = {0: (7, 6), 1: (4, 3), 2: (1, 1), 3: (1, 1)}
_JOINT_TRANSMISSIONS = (0, 1)  # mjtTrn: an actuator driving a joint (mjTRN_JOINT, mjTRN_JOINTINPARENT)
_TOUCH_SENSOR = 0  # mjtSensor.mjSENS_TOUCH


@dataclass(frozen=True)
class Body:
    """A body: `id` indexes xpos, xquat, cfrc_ext. A floating body (a robot's root) has a free joint whose
    coordinates start at qpos `free_qpos_adr` and velocities at qvel `free_dof_adr` (-1 for other bodies),
    whatever that joint is called (a USD floating base has no joint to name it after)."""

    name: str
    id: int
    free_qpos_adr: int = -1
    free_dof_adr: int = -1


@dataclass(frozen=True)
class Site:
    """A site: `id` indexes site_xpos."""

    name: str
    id: int


@dataclass(frozen=True)
class Sensor:
    """A sensor: its readings are `sensordata[:, adr:adr + dim]`."""

    name: str
    adr: int
    dim: int

    @property
    def index(self) -> slice:
        return slice(self.adr, self.adr + self.dim)


@dataclass(frozen=True)
class Touch:
    """A touch sensor: its reading (the normal force of the contacts inside its site's volume) is
    `sensordata[:, adr]`, and `site` indexes site_xpos: where it feels (a gripper's pad)."""

    name: str
    adr: int
    site: int


@dataclass(frozen=True)
class Joint:
    """A joint: its coordinates are `qpos[:, qpos_adr:qpos_adr + qpos_size]`, velocities likewise from dof_adr."""

    name: str
    qpos_adr: int
    qpos_size: int
    dof_adr: int
    dof_size: int


@dataclass(frozen=True)
class Joints:
    """Several joints (an empty name list means every hinge and slide joint): integer index tuples, and
    each qpos entry's position limits (`lower`, `upper`; -inf, inf where the joint has none)."""

    names: tuple[str, ...]
    qpos_index: tuple[int, ...]
    dof_index: tuple[int, ...]
    lower: tuple[float, ...] = ()
    upper: tuple[float, ...] = ()


@dataclass(frozen=True)
class Actuators:
    """Several actuators (an empty name list means all, in actuator order) driving one joint each: the qpos
    and qvel index of each one's joint, so that action i meets the velocity of the joint it drives."""

    names: tuple[str, ...]
    qpos_index: tuple[int, ...]
    dof_index: tuple[int, ...]
    ids: tuple[int, ...] = ()


@dataclass(frozen=True)
class Bodies:
    """Several bodies by name (at least one): `ids` index body_mass, xpos, xfrc_applied."""

    names: tuple[str, ...]
    ids: tuple[int, ...]


@dataclass(frozen=True)
class Geoms:
    """Several geoms by name (at least one): `ids` index geom_friction."""

    names: tuple[str, ...]
    ids: tuple[int, ...]


@dataclass(frozen=True)
class SceneCameras:
    """Several of the scene's cameras by name (at least one): `ids` index cam_pos, cam_quat; `fixed`: whether
    each is fixed in its body (MJCF mode "fixed"), so that cam_pos and cam_quat are its pose there."""

    names: tuple[str, ...]
    ids: tuple[int, ...]
    fixed: tuple[bool, ...]


@dataclass(frozen=True)
class Lights:
    """Several lights by name (at least one): `ids` index light_pos, light_dir, light_diffuse; `fixed`: whether
    each is fixed in its body (MJCF mode "fixed"), so that light_pos and light_dir are its pose there."""

    names: tuple[str, ...]
    ids: tuple[int, ...]
    fixed: tuple[bool, ...]


HANDLE_TYPES = (Body, Site, Sensor, Touch, Joint, Joints, Actuators, Bodies, Geoms, SceneCameras, Lights)
_FIXED_MODE = 0  # mjtCamLight.mjCAMLIGHT_FIXED: a camera or light that moves with its body


def _names(model: Any, kind: str) -> list[str]:
    count = {
        "body": model.nbody,
        "site": model.nsite,
        "sensor": model.nsensor,
        "joint": model.njnt,
        "actuator": model.nu,
        "geom": model.ngeom,
        "camera": model.ncam,
        "light": model.nlight,
    }[kind]
    return [getattr(model, kind)(i).name for i in range(count)]


def _lookup(model: Any, kind: str, name: str) -> int:
    """Index of the named object, or ValueError listing close names and all names."""
    if not isinstance(name, str):
        raise ValueError(f"expected a {kind} name, got {name!r}")
    names = _names(model, kind)
    if name in names:
        return names.index(name)
    close = difflib.get_close_matches(name, names, n=3)
    hint = f" Did you mean: {', '.join(close)}?" if close else ""
    listed = ", ".join(n for n in names if n) or "none"
    plural = "bodies" if kind == "body" else f"{kind}s"
    raise ValueError(f"the model has no {kind} named '{name}'.{hint} Its {plural}: {listed}")


def _joint(model: Any, index: int) -> Joint:
    qpos_size, dof_size = _JOINT_SIZES[int(model.jnt_type[index])]
    return Joint(
        model.joint(index).name, int(model.jnt_qposadr[index]), qpos_size, int(model.jnt_dofadr[index]), dof_size
    )


def resolve_handle(model: Any, handle_type: type, value: Any) -> Any:
    """The handle of `handle_type` for `value` (a name, or for Joints a list of names); ValueError if unknown."""
    if handle_type is Body:
        return _body(model, value)
    if handle_type is Site:
        return Site(value, _lookup(model, "site", value))
    if handle_type is Sensor:
        index = _lookup(model, "sensor", value)
        return Sensor(value, int(model.sensor_adr[index]), int(model.sensor_dim[index]))
    if handle_type is Touch:
        index = _lookup(model, "sensor", value)
        if int(model.sensor_type[index]) != _TOUCH_SENSOR:
            raise ValueError(f"sensor '{value}' is not a touch sensor")
        return Touch(value, int(model.sensor_adr[index]), int(model.sensor_objid[index]))
    if handle_type is Joint:
        return _joint(model, _lookup(model, "joint", value))
    if handle_type is Joints:
        names = _joint_names(model, value)
        ids = [_lookup(model, "joint", name) for name in names]
        joints = [_joint(model, index) for index in ids]
        pairs = zip(ids, joints, strict=True)
        limits = [_limits(model, index) for index, joint in pairs for _ in range(joint.qpos_size)]
        return Joints(
            tuple(names),
            tuple(j.qpos_adr + k for j in joints for k in range(j.qpos_size)),
            tuple(j.dof_adr + k for j in joints for k in range(j.dof_size)),
            tuple(low for low, _ in limits),
            tuple(high for _, high in limits),
        )
    if handle_type is Actuators:
        return _actuators(model, value)
    if handle_type in (Bodies, Geoms):
        kind = "body" if handle_type is Bodies else "geom"
        names = _name_list(value, kind)
        if not names:
            raise ValueError(f"name at least one {kind}")
        return handle_type(tuple(names), tuple(_lookup(model, kind, name) for name in names))
    if handle_type in (SceneCameras, Lights):
        kind = "camera" if handle_type is SceneCameras else "light"
        names = _name_list(value, kind)
        if not names:
            raise ValueError(f"name at least one {kind}")
        indices = tuple(_lookup(model, kind, name) for name in names)
        modes = model.cam_mode if handle_type is SceneCameras else model.light_mode
        return handle_type(tuple(names), indices, tuple(int(modes[i]) == _FIXED_MODE for i in indices))
    raise TypeError(f"not a model handle type: {handle_type!r}")


def _body(model: Any, name: str) -> Body:
    index = _lookup(model, "body", name)
    free = [j for j in range(model.njnt) if int(model.jnt_bodyid[j]) == index and int(model.jnt_type[j]) == _FREE]
    if not free:
        return Body(name, index)
    return Body(name, index, int(model.jnt_qposadr[free[0]]), int(model.jnt_dofadr[free[0]]))


def _actuators(model: Any, value: Any) -> Actuators:
    """The named actuators (all when empty), each of which must drive a joint."""
    names = _name_list(value, "actuator") or [model.actuator(i).name for i in range(model.nu)]
    joints, ids = [], []
    for name in names:
        index = _lookup(model, "actuator", name)
        if int(model.actuator_trntype[index]) not in _JOINT_TRANSMISSIONS:
            raise ValueError(f"actuator '{name}' drives no joint (its transmission is not a joint)")
        joints.append(_joint(model, int(model.actuator_trnid[index][0])))
        ids.append(index)
    return Actuators(tuple(names), tuple(j.qpos_adr for j in joints), tuple(j.dof_adr for j in joints), tuple(ids))


def _limits(model: Any, index: int) -> tuple[float, float]:
    """(lower, upper) position limits of a joint; (-inf, inf) where it is not limited."""
    if not bool(model.jnt_limited[index]):
        return -math.inf, math.inf
    return float(model.jnt_range[index][0]), float(model.jnt_range[index][1])


def _name_list(value: Any, kind: str) -> list[str]:
    """A name or a list of names, as a list (empty: the caller's default)."""
    if isinstance(value, str):
        return [value]
    if not isinstance(value, Sequence):
        raise ValueError(f"expected a list of {kind} names, got {value!r}")
    return list(value)


def _joint_names(model: Any, value: Any) -> list[str]:
    names = _name_list(value, "joint")
    return names or [model.joint(i).name for i in range(model.njnt) if int(model.jnt_type[i]) not in (_FREE, _BALL)]
