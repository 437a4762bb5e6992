"""The kinematic tree: rigid bodies (RigidBodyAPI) linked by UsdPhysics joints through body0/body1, rooted
at the world or, for a floating robot, at its articulation root. As the UsdPhysics reference parser
(UsdPhysics.LoadUsdPhysicsFromRange) reads a body rel: its target stands for the nearest enabled rigid body at or
above it, and a target with none (the asset's root Xform, say) or no target at all is the static world; the
joint's localPos/localRot stay in the target's frame (the stage's frame without a target)."""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field

from pxr import Sdf, Usd, UsdPhysics

from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.stage import prims, read

JOINT_KINDS = (
    (UsdPhysics.RevoluteJoint, "revolute"),
    (UsdPhysics.PrismaticJoint, "prismatic"),
    (UsdPhysics.SphericalJoint, "spherical"),
    (UsdPhysics.FixedJoint, "fixed"),
)


@dataclass(frozen=True)
class JointPrim:
    """A UsdPhysics joint between two rigid bodies (None is the world), and the prims its body rels target, in
    whose frames localPos0/localRot0 and localPos1/localRot1 are given (None: the stage's frame)."""

    prim: Usd.Prim
    kind: str
    body0: Usd.Prim | None
    body1: Usd.Prim | None
    frame0: Usd.Prim | None = None
    frame1: Usd.Prim | None = None


@dataclass
class Link:
    """One MuJoCo body: its rigid-body prim, the joint to its parent (None: free or welded to the world) and
    whether that joint points child -> parent (body0 is the child)."""

    prim: Usd.Prim
    parent: Link | None
    joint: JointPrim | None
    reversed: bool = False
    children: list[Link] = field(default_factory=list)


def rigid_bodies(stage: Usd.Stage, report: ImportReport) -> list[Usd.Prim]:
    """The simulated rigid bodies in stage order; disabled and kinematic ones are warned about."""
    bodies = []
    for prim in prims(stage):
        if not prim.HasAPI(UsdPhysics.RigidBodyAPI):
            continue
        if read(prim, "physics:rigidBodyEnabled", report) is False:
            report.warn(prim.GetPath(), "rigidBodyEnabled is false: imported as static geometry of the world")
            continue
        if read(prim, "physics:kinematicEnabled", report):
            report.warn(prim.GetPath(), "kinematic body: MuJoCo simulates it as dynamic (welded if it is a root)")
        bodies.append(prim)
    return bodies


def joint_prims(stage: Usd.Stage, bodies: set[Sdf.Path], report: ImportReport) -> list[JointPrim]:
    """The enabled joints of the tree; unsupported and loop-closing joints are warned about and skipped."""
    joints = []
    for prim in prims(stage):
        if not prim.IsA(UsdPhysics.Joint):
            continue
        path = prim.GetPath()
        if read(prim, "physics:jointEnabled", report) is False:
            report.warn(path, "jointEnabled is false: ignored")
            continue
        if read(prim, "physics:excludeFromArticulation", report):
            report.warn(path, "excludeFromArticulation (a loop-closing joint) is not supported: ignored")
            continue
        kind = next((name for schema, name in JOINT_KINDS if prim.IsA(schema)), None)
        if kind is None:
            report.warn(path, f"{prim.GetTypeName() or 'generic'} joints are not supported: bodies welded instead")
            kind = "fixed"
        frame0, frame1 = (_joint_target(prim, rel, report) for rel in ("physics:body0", "physics:body1"))
        if frame0 is None and frame1 is None:
            raise report.error(path, "physics:body1", "the joint connects no rigid body (body0 and body1 empty)")
        body0, body1 = (enclosing_body(target, bodies) for target in (frame0, frame1))
        if body0 is not None and body1 is not None and body0.GetPath() == body1.GetPath():
            report.warn(path, f"body0 and body1 are both in the rigid body <{body0.GetPath()}>: ignored")
            continue
        if body0 is None and body1 is None:
            report.warn(path, "neither body0 nor body1 is in a rigid body (both are the static world): ignored")
            continue
        joints.append(JointPrim(prim, kind, body0, body1, frame0, frame1))
    return joints


def _joint_target(prim: Usd.Prim, name: str, report: ImportReport) -> Usd.Prim | None:
    """The prim a joint's body rel targets (None without a target); a missing prim or several are ModelErrors."""
    rel = prim.GetRelationship(name)
    targets = rel.GetForwardedTargets() if rel else []
    if not targets:
        return None
    if len(targets) > 1:
        raise report.error(prim.GetPath(), name, f"has {len(targets)} targets, a joint body needs one")
    target = prim.GetStage().GetPrimAtPath(targets[0])
    if not target:
        raise report.error(prim.GetPath(), name, f"target <{targets[0]}> does not exist")
    return target


def enclosing_body(prim: Usd.Prim | None, bodies: set[Sdf.Path]) -> Usd.Prim | None:
    """`prim` or its nearest ancestor that is a simulated rigid body; None (the static world) if there is none."""
    while prim and not prim.IsPseudoRoot():
        if prim.GetPath() in bodies:
            return prim
        prim = prim.GetParent()
    return None


def build_tree(bodies: list[Usd.Prim], joints: list[JointPrim], report: ImportReport) -> list[Link]:
    """The trees hanging off the world: world-jointed bodies first, then one floating root per remaining group
    (its ArticulationRootAPI body, else a body that is no joint's body1). A cycle is a ModelError."""
    edges: dict[Sdf.Path | None, list[JointPrim]] = {}
    for joint in joints:
        for end in (joint.body0, joint.body1):
            edges.setdefault(end.GetPath() if end else None, []).append(joint)
    links: dict[Sdf.Path, Link] = {}
    used: set[Sdf.Path] = set()
    roots: list[Link] = []
    _grow(None, None, edges, links, used, roots, report)
    children = {joint.body1.GetPath() for joint in joints if joint.body1 is not None and joint.body0 is not None}
    for prim in sorted(bodies, key=lambda body: _root_rank(body, children)):
        if prim.GetPath() not in links:
            root = Link(prim, None, None)
            links[prim.GetPath()] = root
            roots.append(root)
            _grow(prim.GetPath(), root, edges, links, used, roots, report)
    order = {prim.GetPath(): index for index, prim in enumerate(bodies)}
    roots.sort(key=lambda link: order[link.prim.GetPath()])
    return roots


def _root_rank(prim: Usd.Prim, children: set[Sdf.Path]) -> int:
    """Sort key preferring articulation roots, then bodies no joint hangs below another body."""
    if prim.HasAPI(UsdPhysics.ArticulationRootAPI):
        return 0
    return 1 if prim.GetPath() not in children else 2


def _grow(
    start: Sdf.Path | None,
    start_link: Link | None,
    edges: dict[Sdf.Path | None, list[JointPrim]],
    links: dict[Sdf.Path, Link],
    used: set[Sdf.Path],
    roots: list[Link],
    report: ImportReport,
) -> None:
    """Breadth-first from `start` (None: the world), linking every body reached through an unused joint."""
    queue: deque[tuple[Sdf.Path | None, Link | None]] = deque([(start, start_link)])
    while queue:
        path, parent = queue.popleft()
        for joint in edges.get(path, []):
            if joint.prim.GetPath() in used:
                continue
            used.add(joint.prim.GetPath())
            reverse = (joint.body0.GetPath() if joint.body0 else None) != path
            child = joint.body0 if reverse else joint.body1
            assert child is not None  # a joint is reached from a body at one end, so the other end is a body
            if child.GetPath() in links:
                rel = "physics:body0" if reverse else "physics:body1"
                raise report.error(joint.prim.GetPath(), rel, f"closes a kinematic loop at <{child.GetPath()}>")
            link = Link(child, parent, joint, reverse)
            links[child.GetPath()] = link
            (parent.children if parent else roots).append(link)
            queue.append((child.GetPath(), link))


def walk(link: Link) -> Iterator[Link]:
    """`link` and its descendants, parents first."""
    yield link
    for child in link.children:
        yield from walk(child)
