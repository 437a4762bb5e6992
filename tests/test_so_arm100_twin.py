"""The SO-ARM100 twin against the real arm's links: its collision shapes self-penetrate only where the links
touch, LeRobot's rest pose included.

The links stand as generate_meshes.py draws them: every box and cylinder of every link (servos included) is
added to the model as a convex mesh of its own, so that MuJoCo measures the links' distances exactly where the
visual STL (one non-convex mesh per link) would be taken as its convex hull.
"""

from __future__ import annotations

import importlib.util
import itertools
from pathlib import Path

import mujoco
import numpy as np
import pytest

from joshua_lerobot.joints import DEFAULT_UNITS, SO100_JOINTS

ARM_DIR = Path(__file__).parents[1] / "models" / "so_arm100"
LINK_GROUP = 5  # the added link parts: no other geom of the model is in this group
# Collision shapes may sink this far into each other where the links are clear: the validator's default
# penetration threshold (joshua_modes.validation), the depth from which a replay is refused.
FALSE_CONTACT_TOLERANCE = 0.005  # m
REST_TOLERANCE = 0.002  # m: at rest the shapes may touch (the forearm lies on the shoulder), not sink in
LEROBOT_REST = {"shoulder_pan.pos": 0.0, "shoulder_lift.pos": -90.0, "elbow_flex.pos": 90.0, "wrist_flex.pos": 45.0}
GRID_STEPS = 7  # per joint, over the whole range of lift, elbow and wrist flex


def _generator():
    spec = importlib.util.spec_from_file_location("generate_meshes", ARM_DIR / "generate_meshes.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def twin() -> tuple[mujoco.MjModel, list[tuple[int, int]], list[tuple[int, int]]]:
    """The arm with its links' parts added; the collision-geom pairs and the part pairs of bodies that are
    neither equal nor parent and child (which meet at their joint by design)."""
    parts_of = _generator().MESHES
    spec = mujoco.MjSpec.from_file(str(ARM_DIR / "so_arm100.xml"))
    for geom in list(spec.geoms):
        if geom.type != mujoco.mjtGeom.mjGEOM_MESH:
            continue
        for index, part in enumerate(parts_of[geom.meshname]()):
            name = f"{geom.parent.name}_{geom.meshname}_{index}_{len(spec.meshes)}"
            spec.add_mesh(name=name, uservert=np.asarray(part.vertices, dtype=float).ravel().tolist())
            # contype/conaffinity of their own: MuJoCo builds a mesh's convex hull only for colliding geoms
            added = geom.parent.add_geom(
                type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name, pos=geom.pos, quat=geom.quat, group=LINK_GROUP
            )
            added.contype, added.conaffinity, added.density = 8, 8, 0
            added.alt.type, added.alt.xyaxes = geom.alt.type, geom.alt.xyaxes
    model = spec.compile()

    def pairs(geoms: list[int]) -> list[tuple[int, int]]:
        found = []
        for first, second in itertools.combinations(geoms, 2):
            body1, body2 = model.geom_bodyid[first], model.geom_bodyid[second]
            if body1 != body2 and model.body_parentid[body1] != body2 and model.body_parentid[body2] != body1:
                found.append((first, second))
        return found

    collision = [g for g in range(model.ngeom) if model.geom_contype[g] and model.geom_group[g] == 3]
    links = [g for g in range(model.ngeom) if model.geom_group[g] == LINK_GROUP]
    return model, pairs(collision), pairs(links)


def _distances(
    model: mujoco.MjModel, data: mujoco.MjData, pairs: list[tuple[int, int]]
) -> dict[tuple[str, str], float]:
    """The smallest signed distance (m, negative: penetration) per pair of bodies at data's pose."""
    nearest: dict[tuple[str, str], float] = {}
    for first, second in pairs:
        key = (model.body(model.geom_bodyid[first]).name, model.body(model.geom_bodyid[second]).name)
        distance = mujoco.mj_geomDistance(model, data, first, second, 0.05, None)
        nearest[key] = min(nearest.get(key, np.inf), distance)
    return nearest


def _pose(model: mujoco.MjModel, data: mujoco.MjData, qpos: np.ndarray) -> None:
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)


def test_lerobot_rest_pose_does_not_self_penetrate(twin) -> None:
    model, collision, links = twin
    data = mujoco.MjData(model)
    qpos = np.zeros(model.nq)
    for name, degrees in LEROBOT_REST.items():
        joint = model.joint(SO100_JOINTS[name])
        qpos[joint.qposadr[0]] = DEFAULT_UNITS.to_model(name, np.array([degrees]), tuple(joint.range))[0]
    np.testing.assert_allclose(np.degrees(qpos[:4]), [0, -90, 90, 45], atol=1e-9)  # our zeros are LeRobot's
    _pose(model, data, qpos)
    shapes = _distances(model, data, collision)
    assert min(shapes.values()) > -REST_TOLERANCE, {pair: d for pair, d in shapes.items() if d < 0}
    assert min(_distances(model, data, links).values()) > -REST_TOLERANCE


def test_collision_shapes_penetrate_only_where_the_links_touch(twin) -> None:
    """Over a grid of the joint ranges (pan, roll and jaw at two settings each): at every pose where the links'
    parts are apart (a pose the real arm reaches), no two collision shapes sink deeper than the tolerance into
    each other; at the poses where the links are folded into each other the collision shapes report it too
    (self-collision is modelled, not switched off)."""
    model, collision, links = twin
    data = mujoco.MjData(model)
    ranges = model.jnt_range
    grids = [np.linspace(ranges[j, 0], ranges[j, 1], GRID_STEPS) for j in (1, 2, 3)]
    false_contacts, reached, folded, folded_seen = [], 0, 0, 0
    for (lift, elbow, flex), (pan, roll, jaw) in itertools.product(
        itertools.product(*grids), [(0.0, 0.0, 0.0), (0.9, 1.5, 1.0)]
    ):
        _pose(model, data, np.array([pan, lift, elbow, flex, roll, jaw]))
        shapes, parts = _distances(model, data, collision), _distances(model, data, links)
        deepest = min(shapes.values())
        if min(parts.values()) > 0:
            reached += 1
            if deepest < -FALSE_CONTACT_TOLERANCE:
                where = np.degrees([pan, lift, elbow, flex]).round()
                false_contacts.append((min(shapes, key=shapes.__getitem__), round(deepest * 1000, 1), where))
        elif min(parts.values()) < -FALSE_CONTACT_TOLERANCE:
            folded += 1
            folded_seen += deepest < 0
    assert not false_contacts, false_contacts[:10]
    assert reached > 300 and folded > 50  # both kinds of pose are in the grid (686 poses)
    assert folded_seen == folded
