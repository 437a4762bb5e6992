"""Scene-wide settings: PhysicsScene gravity and time step, PhysX articulation solver iterations and
self-collision, CollisionGroups as contype/conaffinity bits and FilteredPairsAPI as MuJoCo contact exclusions."""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator

import mujoco
import numpy as np
from pxr import Sdf, Usd, UsdPhysics

from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.stage import StageFrame, prims, read, read_physx
from joshua_usd.importer.topology import Link, walk
from joshua_usd.physx_schema import attribute_name

EARTH_GRAVITY = 9.80665  # m/s^2, UsdPhysics' default magnitude
OPTION_PREFIX = "joshua:option:"  # MuJoCo solver settings the exporter writes on the PhysicsScene
MAX_GROUPS = 31  # MuJoCo's contype/conaffinity have 32 bits: one per group and one for colliders in none


def set_scene(spec: mujoco.MjSpec, stage: Usd.Stage, frame: StageFrame, report: ImportReport) -> None:
    """Gravity (direction and magnitude in stage units, default: Earth's along -up), the time step
    (physxScene:timeStepsPerSecond; MuJoCo's default otherwise) and joshua:option:* of the first PhysicsScene."""
    scenes = [prim for prim in prims(stage) if prim.IsA(UsdPhysics.Scene)]
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
    steps = read_physx(scene, "PhysxSceneAPI", "timeStepsPerSecond", report)
    if steps is not None:
        if steps <= 0:
            name = attribute_name("PhysxSceneAPI", "timeStepsPerSecond")
            raise report.error(scene.GetPath(), name, f"must be positive, got {steps}")
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
    spec: mujoco.MjSpec,
    stage: Usd.Stage,
    roots: list[Link],
    names: dict[Sdf.Path, str],
    static: set[Sdf.Path],
    report: ImportReport,
) -> None:
    """Per ArticulationRootAPI prim: enabledSelfCollisions false excludes contacts between all its bodies;
    the largest solverPositionIterationCount becomes MuJoCo's solver iterations. FilteredPairsAPI targets are
    rigid bodies or `static` colliders (the world's)."""
    iterations = []
    for prim in prims(stage):
        if not prim.HasAPI(UsdPhysics.ArticulationRootAPI):
            continue
        count = read_physx(prim, "PhysxArticulationAPI", "solverPositionIterationCount", report)
        if count is not None:
            iterations.append(int(count))
        if read_physx(prim, "PhysxArticulationAPI", "enabledSelfCollisions", report) is False:
            bodies = [link.prim.GetPath() for link in _articulation(prim.GetPath(), roots)]
            for first, second in itertools.combinations(bodies, 2):
                spec.add_exclude(bodyname1=names[first], bodyname2=names[second])
    if iterations:
        spec.option.iterations = max(iterations)
    for prim in prims(stage):
        if prim.HasAPI(UsdPhysics.FilteredPairsAPI) and prim.GetPath() in names:
            excluded = set()
            for target in prim.GetRelationship("physics:filteredPairs").GetForwardedTargets():
                if target in names:
                    excluded.add(names[target])
                elif target in static:  # a collider of the world: MuJoCo excludes whole bodies
                    excluded.add("world")
                else:
                    report.warn(prim.GetPath(), f"filtered pair <{target}> is not a rigid body: ignored")
            for other in sorted(excluded):
                spec.add_exclude(bodyname1=names[prim.GetPath()], bodyname2=other)


def set_collision_groups(stage: Usd.Stage, colliders: dict[Sdf.Path, mujoco.MjsGeom], report: ImportReport) -> None:
    """CollisionGroups as contype/conaffinity bits: group i's colliders get contype bit i and, in conaffinity,
    the bit of every group they may touch (neither group filters the other); colliders in no group get the next
    bit and touch every group. So two colliders touch in MuJoCo exactly where their groups let them in PhysX."""
    groups = [UsdPhysics.CollisionGroup(prim) for prim in prims(stage) if prim.IsA(UsdPhysics.CollisionGroup)]
    if not groups:
        return
    if len(groups) > MAX_GROUPS:
        report.warn(groups[MAX_GROUPS].GetPath(), f"more than {MAX_GROUPS} collision groups: all ignored")
        return
    index = {group.GetPath(): number for number, group in enumerate(groups)}
    filtered: set[frozenset[int]] = set()
    for group in groups:
        for target in group.GetFilteredGroupsRel().GetForwardedTargets():
            if target in index:
                filtered.add(frozenset((index[group.GetPath()], index[target])))
            else:
                report.warn(group.GetPath(), f"filtered group <{target}> is not a collision group: ignored")
    member: dict[Sdf.Path, int] = {}
    for number, group in enumerate(groups):
        query = group.GetCollidersCollectionAPI().ComputeMembershipQuery()
        for path in colliders:
            if query.IsPathIncluded(path) and member.setdefault(path, number) != number:
                report.warn(path, f"in several collision groups: only <{groups[member[path]].GetPath()}> kept")
    ungrouped = len(groups)
    for path, geom in colliders.items():
        number = member.get(path, ungrouped)
        touched = [other for other in range(ungrouped) if number == ungrouped or {number, other} not in filtered]
        geom.contype = 1 << number
        geom.conaffinity = sum(1 << other for other in touched) | 1 << ungrouped


def _articulation(root: Sdf.Path, roots: list[Link]) -> Iterator[Link]:
    """The links of every tree with a body at or below the articulation root prim."""
    for top in roots:
        tree = list(walk(top))
        if any(link.prim.GetPath().HasPrefix(root) for link in tree):
            yield from tree
