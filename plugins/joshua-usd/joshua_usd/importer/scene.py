"""Scene-wide settings: PhysicsScene gravity and time step, PhysX articulation solver iterations and
self-collision, and FilteredPairsAPI as MuJoCo contact exclusions."""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator

import mujoco
import numpy as np
from pxr import Sdf, Usd, UsdPhysics

from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.stage import StageFrame, prims, read
from joshua_usd.importer.topology import Link, walk

EARTH_GRAVITY = 9.80665  # m/s^2, UsdPhysics' default magnitude
OPTION_PREFIX = "joshua:option:"  # MuJoCo solver settings the exporter writes on the PhysicsScene


def set_scene(spec: mujoco.MjSpec, stage: Usd.Stage, frame: StageFrame, report: ImportReport) -> None:
    """Gravity (direction and magnitude in stage units, default: Earth's along -up), the time step
    (physxScene:timeStepsPerSecond; MuJoCo's default otherwise) and joshua:option:* of the first PhysicsScene."""
    scenes = [prim for prim in prims(stage) if prim.IsA(UsdPhysics.Scene)]
    for group in (prim for prim in prims(stage) if prim.IsA(UsdPhysics.CollisionGroup)):
        report.warn(group.GetPath(), "collision groups are not supported: every collider may touch every other")
    for extra in scenes[1:]:
        report.warn(extra.GetPath(), "only the first PhysicsScene is used: ignored")
    if not scenes:
        return
    scene = scenes[0]
    direction = np.asarray(read(scene, "physics:gravityDirection", report), dtype=np.float64)
    magnitude = read(scene, "physics:gravityMagnitude", report, allow_inf=True)
    if np.linalg.norm(direction) > 0:
        direction = frame.to_mujoco[:3, :3] @ direction
        direction /= np.linalg.norm(direction)
    else:
        direction = np.array([0.0, 0.0, -1.0])
    gravity = EARTH_GRAVITY if magnitude is None or math.isinf(magnitude) else magnitude * frame.meters_per_unit
    spec.option.gravity = direction * gravity
    steps = read(scene, "physxScene:timeStepsPerSecond", report)
    if steps is not None:
        if steps <= 0:
            raise report.error(scene.GetPath(), "physxScene:timeStepsPerSecond", f"must be positive, got {steps}")
        spec.option.timestep = 1.0 / steps
    _set_options(spec, scene, report)


def _set_options(spec: mujoco.MjSpec, scene: Usd.Prim, report: ImportReport) -> None:
    """The exporter's joshua:option:* (integrator, cone, impratio): MuJoCo settings UsdPhysics has no
    attribute for; unknown names are warned about and MuJoCo's defaults kept."""
    for name, enum, prefix in (("integrator", mujoco.mjtIntegrator, "mjINT_"), ("cone", mujoco.mjtCone, "mjCONE_")):
        value = read(scene, OPTION_PREFIX + name, report)
        if value is None:
            continue
        member = getattr(enum, prefix + str(value).upper(), None)
        if member is None:
            report.warn(scene.GetPath(), f"{OPTION_PREFIX}{name} {value!r} is not a MuJoCo {name}: ignored")
        else:
            setattr(spec.option, name, member)
    impratio = read(scene, OPTION_PREFIX + "impratio", report)
    if impratio is not None:
        if impratio <= 0:
            raise report.error(scene.GetPath(), OPTION_PREFIX + "impratio", f"must be positive, got {impratio}")
        spec.option.impratio = float(impratio)


def set_articulations(
    spec: mujoco.MjSpec, stage: Usd.Stage, roots: list[Link], names: dict[Sdf.Path, str], report: ImportReport
) -> None:
    """Per ArticulationRootAPI prim: enabledSelfCollisions false excludes contacts between all its bodies;
    the largest solverPositionIterationCount becomes MuJoCo's solver iterations."""
    iterations = []
    for prim in prims(stage):
        if not prim.HasAPI(UsdPhysics.ArticulationRootAPI):
            continue
        count = read(prim, "physxArticulation:solverPositionIterationCount", report)
        if count is not None:
            iterations.append(int(count))
        if read(prim, "physxArticulation:enabledSelfCollisions", report) is False:
            bodies = [link.prim.GetPath() for link in _articulation(prim.GetPath(), roots)]
            for first, second in itertools.combinations(bodies, 2):
                spec.add_exclude(bodyname1=names[first], bodyname2=names[second])
    if iterations:
        spec.option.iterations = max(iterations)
    for prim in prims(stage):
        if prim.HasAPI(UsdPhysics.FilteredPairsAPI) and prim.GetPath() in names:
            for target in prim.GetRelationship("physics:filteredPairs").GetForwardedTargets():
                if target in names:
                    spec.add_exclude(bodyname1=names[prim.GetPath()], bodyname2=names[target])
                else:
                    report.warn(prim.GetPath(), f"filtered pair <{target}> is not a rigid body: ignored")


def _articulation(root: Sdf.Path, roots: list[Link]) -> Iterator[Link]:
    """The links of every tree with a body at or below the articulation root prim."""
    for top in roots:
        tree = list(walk(top))
        if any(link.prim.GetPath().HasPrefix(root) for link in tree):
            yield from tree

