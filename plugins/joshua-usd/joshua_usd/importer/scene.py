"""Scene-wide settings: PhysicsScene gravity, time step and solver options (Newton's, MuJoCo's, PhysX's),
articulation self-collision, CollisionGroups as contype/conaffinity bits and FilteredPairsAPI as MuJoCo contact
exclusions."""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator

import mujoco
import numpy as np
from pxr import Sdf, Usd, UsdPhysics

from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.solver_options import set_solver_options
from joshua_usd.importer.stage import StageFrame, applied, prims, read, read_authored, read_number, read_physx
from joshua_usd.importer.topology import Link, walk
from joshua_usd.physx_schema import attribute_name

EARTH_GRAVITY = 9.80665  # m/s^2, UsdPhysics' default magnitude
NEWTON_STEPS_PER_SECOND = 1000  # NewtonSceneAPI's fallback of newton:timeStepsPerSecond
MAX_GROUPS = 31  # MuJoCo's contype/conaffinity have 32 bits: one per group and one for colliders in none


def physics_scene(stage: Usd.Stage, report: ImportReport) -> Usd.Prim | None:
    """The first PhysicsScene (further ones are warned about and ignored), None when there is none."""
    scenes = [prim for prim in prims(stage) if prim.IsA(UsdPhysics.Scene)]
    for extra in scenes[1:]:
        report.warn(extra.GetPath(), "only the first PhysicsScene is used: ignored")
    return scenes[0] if scenes else None


def set_scene(spec: mujoco.MjSpec, scene: Usd.Prim, frame: StageFrame, report: ImportReport) -> bool:
    """Gravity (direction and magnitude in stage units, default: Earth's along -up; newton:gravityEnabled), the time
    step and MuJoCo's solver options of the PhysicsScene `scene`. Returns whether the scene set the solver iterations
    (newton:maxSolverIterations or mjc:option:iterations), which then take precedence over PhysX's articulations'."""
    direction = np.asarray(read(scene, "physics:gravityDirection", report), dtype=np.float64)
    magnitude = read(scene, "physics:gravityMagnitude", report, allow_inf=True)
    if np.linalg.norm(direction) > 0:
        direction = frame.to_mujoco[:3, :3] @ direction
        direction /= np.linalg.norm(direction)
    else:
        direction = np.array([0.0, 0.0, -1.0])
    gravity = EARTH_GRAVITY if magnitude is None or math.isinf(magnitude) else magnitude * frame.meters_per_unit
    spec.option.gravity = direction * gravity
    _set_timestep(spec, scene, report)
    set_solver_options(spec, scene, report)
    enabled = read_number(scene, "newton:gravityEnabled", report, authored=True)
    if enabled is not None:
        gravity_bit = int(mujoco.mjtDisableBit.mjDSBL_GRAVITY)
        spec.option.disableflags = spec.option.disableflags & ~gravity_bit | (0 if enabled else gravity_bit)
    return _set_iterations(spec, scene, report)


def _set_timestep(spec: mujoco.MjSpec, scene: Usd.Prim, report: ImportReport) -> None:
    """The first authored of newton:timeStepsPerSecond (Hz), mjc:option:timestep (s, deprecated by Newton's) and
    physxScene:timeStepsPerSecond (Hz); else NewtonSceneAPI's fallback of 1000 Hz where it (or MjcSceneAPI, which
    includes it) is applied; else MuJoCo's 0.002 s. A non-positive value is a ModelError."""
    physx = attribute_name("PhysxSceneAPI", "timeStepsPerSecond")
    candidates = (("newton:timeStepsPerSecond", True), ("mjc:option:timestep", False), (physx, True))
    found = next(
        (
            (name, value, hertz)
            for name, hertz in candidates
            if (value := read_number(scene, name, report, authored=True)) is not None
        ),
        None,
    )
    if found is None:
        if not any(applied(scene, api) for api in ("NewtonSceneAPI", "MjcSceneAPI")):
            return
        found = ("newton:timeStepsPerSecond", NEWTON_STEPS_PER_SECOND, True)
    name, value, hertz = found
    if value <= 0:
        raise report.error(scene.GetPath(), name, f"must be positive, got {value}")
    spec.option.timestep = 1.0 / value if hertz else value


def _set_iterations(spec: mujoco.MjSpec, scene: Usd.Prim, report: ImportReport) -> bool:
    """newton:maxSolverIterations (-1: the solver's own, MuJoCo's 100), else the deprecated mjc:option:iterations,
    as MuJoCo's solver iterations; whether either is authored."""
    for name in ("newton:maxSolverIterations", "mjc:option:iterations"):
        value = read_number(scene, name, report, integer=True, authored=True)
        if value is None:
            continue
        if value < -1 or (value in (-1, 0) and name == "mjc:option:iterations"):
            raise report.error(scene.GetPath(), name, f"must be -1 or positive, got {value}")
        if value > 0:
            spec.option.iterations = int(value)
        return True
    return False


def set_articulations(
    spec: mujoco.MjSpec,
    stage: Usd.Stage,
    roots: list[Link],
    names: dict[Sdf.Path, str],
    static: set[Sdf.Path],
    report: ImportReport,
    *,
    scene_iterations: bool,
) -> None:
    """Per ArticulationRootAPI prim: self-collision disabled (newton:selfCollisionEnabled, else PhysX's
    enabledSelfCollisions) excludes contacts between all its bodies; the largest solverPositionIterationCount
    becomes MuJoCo's solver iterations unless the scene set them (`scene_iterations`). FilteredPairsAPI targets are
    rigid bodies or `static` colliders (the world's)."""
    iterations = []
    for prim in prims(stage):
        if not prim.HasAPI(UsdPhysics.ArticulationRootAPI):
            continue
        if not scene_iterations:
            count = read_physx(prim, "PhysxArticulationAPI", "solverPositionIterationCount", report)
            iterations += [] if count is None else [int(count)]
        self_collisions = read_authored(prim, "newton:selfCollisionEnabled", report)
        if self_collisions is None:
            self_collisions = read_physx(prim, "PhysxArticulationAPI", "enabledSelfCollisions", report)
        if self_collisions is not None and not self_collisions:
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
