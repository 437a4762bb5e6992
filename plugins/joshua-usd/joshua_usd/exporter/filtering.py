"""MuJoCo's contact filtering in UsdPhysics terms. Each (contype, conaffinity) pair the colliders have becomes
a CollisionGroup under /CollisionGroups whose filteredGroups are the groups it cannot touch (itself among them
where its geoms cannot touch each other), and each <exclude> body pair a FilteredPairsAPI on the first body.
Without them every exported collider touched every other: the pick-and-place cube, which touches only the
table and the fingertips, would have hit the whole arm. The groups lie beside /PhysicsScene, as scene-wide
settings: a reference to the robot (the default prim) brings the exclusions, not the groups."""

from __future__ import annotations

import itertools

import mujoco
from pxr import Sdf, UsdPhysics

from joshua_usd.exporter.context import Context

GROUPS = Sdf.Path("/CollisionGroups")
Bits = tuple[int, int]  # a geom's (contype, conaffinity)


def bits(model: mujoco.MjModel, geom: int) -> Bits:
    """A geom's (contype, conaffinity)."""
    return int(model.geom_contype[geom]), int(model.geom_conaffinity[geom])


def can_touch(first: Bits, second: Bits) -> bool:
    """MuJoCo's test: a contype bit of either geom is set in the other's conaffinity."""
    return bool(first[0] & second[1] or second[0] & first[1])


def write_filtering(ctx: Context) -> None:
    """Collision groups where some colliders cannot touch others, and the model's body exclusions."""
    classes: dict[Bits, list[Sdf.Path]] = {}
    for geom, path in sorted(ctx.collider_paths.items()):
        classes.setdefault(bits(ctx.model, geom), []).append(path)
    if not all(can_touch(first, second) for first, second in itertools.combinations_with_replacement(classes, 2)):
        _write_groups(ctx, classes)
    _write_exclusions(ctx)


def _write_groups(ctx: Context, classes: dict[Bits, list[Sdf.Path]]) -> None:
    paths = {pair: GROUPS.AppendChild(f"contype{pair[0]}_conaffinity{pair[1]}") for pair in classes}
    ctx.stage.DefinePrim(GROUPS, "Scope")
    for pair, members in classes.items():
        group = UsdPhysics.CollisionGroup.Define(ctx.stage, paths[pair])
        includes = group.GetCollidersCollectionAPI().CreateIncludesRel()
        for member in members:
            includes.AddTarget(member)
        filtered = [paths[other] for other in classes if not can_touch(pair, other)]
        if filtered:
            group.CreateFilteredGroupsRel().SetTargets(filtered)


def _write_exclusions(ctx: Context) -> None:
    """FilteredPairsAPI on the first body of each excluded pair; the world has no prim of its own, so a pair
    with it targets the world's colliders."""
    model = ctx.model
    world = [path for geom, path in sorted(ctx.collider_paths.items()) if model.geom_bodyid[geom] == 0]
    for signature in model.exclude_signature:
        first, second = sorted((int(signature) >> 16, int(signature) & 0xFFFF), reverse=True)
        targets = world if second == 0 else [ctx.body_paths[second]]
        if not targets:
            continue
        prim = ctx.stage.GetPrimAtPath(ctx.body_paths[first])
        relationship = UsdPhysics.FilteredPairsAPI.Apply(prim).CreateFilteredPairsRel()
        for target in targets:
            relationship.AddTarget(target)
