"""What every export step shares: the compiled model at its reference pose, the stage being written,
the prim path of each body, unique prim names, and the notes on what could not be exported."""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike
from pxr import Sdf, Tf, Usd, UsdGeom

from joshua_usd import physx_schema
from joshua_usd.exporter.frames import Pose, gf_quatd, gf_vec3d

ENVIRONMENT = Sdf.Path("/Environment")  # world geoms, cameras and sensors: beside the robot, not in it
NOTES_ATTR = "joshua:notExported"  # string[] on the articulation root: what the exporter left out, and why


@dataclass
class Context:
    """The model (at qpos0) and the stage under construction."""

    model: mujoco.MjModel
    data: mujoco.MjData
    stage: Usd.Stage
    root: Sdf.Path
    body_paths: dict[int, Sdf.Path] = field(default_factory=dict)
    collider_paths: dict[int, Sdf.Path] = field(default_factory=dict)  # by geom id
    notes: list[str] = field(default_factory=list)
    _taken: defaultdict[Sdf.Path, set[str]] = field(default_factory=lambda: defaultdict(set))
    _scopes: dict[str, Sdf.Path] = field(default_factory=dict)

    def name(self, objtype: mujoco.mjtObj, index: int, fallback: str) -> str:
        """The MuJoCo name of an object, or `fallback` with its index when it has none."""
        return mujoco.mj_id2name(self.model, objtype, index) or f"{fallback}{index}"

    def child_path(self, parent: Sdf.Path, name: str) -> Sdf.Path:
        """A path under `parent` named after `name`: a valid prim name, unique among its siblings."""
        base = Tf.MakeValidIdentifier(name)
        candidate, number = base, 1
        while candidate in self._taken[parent]:
            number += 1
            candidate = f"{base}_{number}"
        self._taken[parent].add(candidate)
        return parent.AppendChild(candidate)

    def scope(self, name: str) -> Sdf.Path:
        """A Scope under the root that groups non-body prims (joints, looks, physics materials)."""
        if name not in self._scopes:
            self._scopes[name] = self.child_path(self.root, name)
            self.stage.DefinePrim(self._scopes[name], "Scope")
        return self._scopes[name]

    def parent_path(self, body: int) -> Sdf.Path:
        """Where a body's geoms, cameras and sensors go: the body's prim, or /Environment for the world."""
        if body:
            return self.body_paths[body]
        if not self.stage.GetPrimAtPath(ENVIRONMENT):
            UsdGeom.Xform.Define(self.stage, ENVIRONMENT)
        return ENVIRONMENT

    def body_pose(self, body: int) -> Pose:
        """A body's world frame at the reference configuration."""
        return Pose(self.data.xpos[body].copy(), self.data.xquat[body].copy())

    def note(self, text: str) -> None:
        self.notes.append(text)


def set_pose(prim: Usd.Prim, pos: ArrayLike, quat: ArrayLike, scale: ArrayLike | None = None) -> None:
    """Author translate and orient (double precision), and a scale where given, as the prim's xformOps."""
    xformable = UsdGeom.Xformable(prim)
    xformable.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble).Set(gf_vec3d(pos))
    xformable.AddOrientOp(UsdGeom.XformOp.PrecisionDouble).Set(gf_quatd(quat))
    if scale is not None:
        xformable.AddScaleOp(UsdGeom.XformOp.PrecisionDouble).Set(gf_vec3d(scale))


def set_raw(prim: Usd.Prim, name: str, value_type: Sdf.ValueTypeName, value: Any, *, custom: bool = False) -> None:
    """Author an attribute by name: joshua:* ones and the attributes of Isaac's prim types (no schema in usd-core)."""
    prim.CreateAttribute(name, value_type, custom=custom).Set(value)


def set_physx(
    prim: Usd.Prim,
    api: str,
    name: str,
    value_type: Sdf.ValueTypeName,
    value: Any,
    instance: str = "",
    *,
    uniform: bool = False,
) -> None:
    """Apply the PhysX API schema `api` (its `instance` where multiple-apply) and author its property `name`,
    named by the PhysX schemas; type and variability as theirs (physx_schema.check_stage compares), given here
    so that the file is the same whether the schemas are registered or not."""
    physx_schema.apply(prim, api, instance)
    variability = Sdf.VariabilityUniform if uniform else Sdf.VariabilityVarying
    attribute_name = physx_schema.attribute_name(api, name, instance)
    prim.CreateAttribute(attribute_name, value_type, False, variability).Set(value)


def per_degree(value: float) -> float:
    """An SI rate per radian as USD's per-degree value (angular drive gains, viscous friction)."""
    return float(value) * np.pi / 180.0
