"""USD stage -> MjSpec: the tree of bodies and joints, drives, geoms, scene settings, mass properties, cameras and
sensors."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
from pxr import Sdf, Usd

from joshua_usd.importer.drives import add_drive
from joshua_usd.importer.geoms import add_geom, shapes
from joshua_usd.importer.joint_dynamics import joint_properties
from joshua_usd.importer.joints import add_joint, place
from joshua_usd.importer.mass import probe, set_inertial
from joshua_usd.importer.mjc_actuators import add_mjc_actuators, mjc_actuators
from joshua_usd.importer.pose import IDENTITY, Pose, Vec
from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.scene import physics_scene, set_articulations, set_collision_groups, set_scene
from joshua_usd.importer.sensors import add_cameras, add_sensors
from joshua_usd.importer.solver_options import angle_unit
from joshua_usd.importer.stage import StageFrame, open_stage, read
from joshua_usd.importer.topology import Link, build_tree, enclosing_body, joint_prims, rigid_bodies, walk

TARGETS_KEYFRAME = "drive_targets"  # qpos0 with every drive's target as ctrl


@dataclass
class Imported:
    """The spec of a stage, what the import warned about, and the stage's units."""

    spec: mujoco.MjSpec
    report: ImportReport
    frame: StageFrame


@dataclass(frozen=True)
class _Body:
    """A MuJoCo body with the stage pose and scale of its prim (geoms are placed relative to these)."""

    spec: mujoco.MjsBody
    pose: Pose
    scale: Vec


def import_usd(path: Path) -> Imported:
    """Read the composed stage at `path` into a MuJoCo spec (metres, Z up, radians, SI)."""
    report = ImportReport(path)
    stage = open_stage(path, report)
    frame = StageFrame.of(stage, report)
    bodies = rigid_bodies(stage, report)
    body_paths = {body.GetPath() for body in bodies}
    roots = build_tree(bodies, joint_prims(stage, body_paths, report), report)
    links = [link for root in roots for link in walk(root)]
    spec = mujoco.MjSpec()
    spec.modelname = path.stem
    spec.compiler.degree = False
    names = unique_names((link.prim.GetPath() for link in links), reserved={"world"})
    scene = physics_scene(stage, report)
    made, joints, targets = _add_links(spec, links, names, frame, angle_unit(scene, report), report)
    found_actuators = list(mjc_actuators(stage))
    actuator_names = unique_names(
        (prim.GetPath() for prim in found_actuators), reserved={actuator.name for actuator in spec.actuators}
    )
    bodies_made = {path: body.spec for path, body in made.items()}
    added = add_mjc_actuators(spec, found_actuators, actuator_names, joints, bodies_made, frame, report)
    targets += [0.0] * added  # mjcPhysics holds no target: their ctrl stays MuJoCo's 0
    found = shapes(stage, body_paths, report)
    geom_names = unique_names(shape.prim.GetPath() for shape in found)
    world = _Body(spec.worldbody, IDENTITY, np.ones(3))
    colliders: dict[Sdf.Path, mujoco.MjsGeom] = {}
    for shape in found:
        body = made[shape.owner.GetPath()] if shape.owner is not None else world
        geom = add_geom(spec, body.spec, body.pose, shape, geom_names[shape.prim.GetPath()], frame, report)
        if geom is not None and shape.collider:
            colliders[shape.prim.GetPath()] = geom
    scene_iterations = scene is not None and set_scene(spec, scene, frame, report)
    set_collision_groups(stage, colliders, report)
    static = {shape.prim.GetPath() for shape in found if shape.owner is None and shape.collider}
    set_articulations(spec, stage, roots, names, static, report, scene_iterations=scene_iterations)
    model = probe(spec, report)
    for link in links:
        body = made[link.prim.GetPath()]
        set_inertial(body.spec, link.prim, body.scale, model, frame, report)

    def body_of(prim: Usd.Prim | None) -> tuple[mujoco.MjsBody, Pose]:
        owner = enclosing_body(prim, body_paths)
        body = made[owner.GetPath()] if owner is not None else world
        return body.spec, body.pose

    add_cameras(stage, body_of, frame, report)
    add_sensors(spec, stage, body_paths, body_of, model, frame, report)
    if any(targets):
        spec.add_key(name=TARGETS_KEYFRAME, qpos=model.qpos0, ctrl=targets)
    for kind, named in (("body", names), ("geom", geom_names)):
        report.sources.update({(kind, name): str(path) for path, name in named.items()})
    return Imported(spec, report, frame)


def _add_links(
    spec: mujoco.MjSpec,
    links: list[Link],
    names: dict[Sdf.Path, str],
    frame: StageFrame,
    angle: float,
    report: ImportReport,
) -> tuple[dict[Sdf.Path, _Body], dict[Sdf.Path, mujoco.MjsJoint], list[float]]:
    """Add every link (parents first) as a body with its joint and drive (`angle`: radians per unit of MuJoCo's
    angles in mjc:* attributes); returns the bodies and the MuJoCo joints by prim path and the drive targets in
    actuator order."""
    joint_names = unique_names(link.joint.prim.GetPath() for link in links if link.joint is not None)
    made: dict[Sdf.Path, _Body] = {}
    joints: dict[Sdf.Path, mujoco.MjsJoint] = {}
    targets: list[float] = []
    for link in links:
        placement = place(link, frame, report)
        parent = made[link.parent.prim.GetPath()].spec if link.parent is not None else spec.worldbody
        pose = placement.in_parent
        body = parent.add_body(name=names[link.prim.GetPath()], pos=pose.pos, quat=pose.quat)
        made[link.prim.GetPath()] = _Body(body, *frame.world_pose(link.prim))
        if link.joint is None:
            if not read(link.prim, "physics:kinematicEnabled", report):
                body.add_freejoint(name=read(link.prim, "joshua:freeJoint", report) or "")
            continue
        joint_name = joint_names[link.joint.prim.GetPath()]
        report.sources["joint", joint_name] = str(link.joint.prim.GetPath())
        joint = add_joint(body, link, placement, joint_name, frame, report)
        if joint is not None:
            joints[link.joint.prim.GetPath()] = joint
            joint_properties(link.joint.prim, joint, frame, angle, report)
            target = add_drive(spec, link.joint.prim, joint, frame, report)
            targets += [] if target is None else [target]
    return made, joints, targets


def unique_names(paths: Iterable[Sdf.Path], reserved: set[str] | None = None) -> dict[Sdf.Path, str]:
    """MuJoCo names: each prim's name, or where names collide the shortest path tail that is unique."""
    paths = list(paths)
    taken = reserved or set()
    names: dict[Sdf.Path, str] = {}
    for depth in range(1, max((path.pathElementCount for path in paths), default=0) + 1):
        pending = [path for path in paths if path not in names]
        tails = {path: "/".join(str(path).split("/")[-depth:]) for path in pending}
        counts = Counter(tails.values())
        names.update({path: tail for path, tail in tails.items() if counts[tail] == 1 and tail not in taken})
    return {path: names.get(path, str(path).lstrip("/")) for path in paths}
