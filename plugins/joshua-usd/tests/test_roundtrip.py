"""MJCF -> USD (exporter) -> MuJoCo (importer): the same robot comes back.

Compared: joint names, types, ranges and passive properties; actuators; solver options; body masses and
inertias; joint anchors and axes in the world at random poses; and the trajectory under the same controls
for 1 s, all on the model exactly as imported.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import mujoco
import numpy as np
import pytest
from pxr import Usd, UsdPhysics

from joshua_core.resources import models_dir
from joshua_usd.exporter import export_model
from joshua_usd.importer import import_usd

MODELS = {"so100": "so_arm100/so_arm100.xml", "ant": "ant/ant.xml", "trileg": "trileg/trileg.xml"}
SOLVER_OPTIONS = ("integrator", "cone", "impratio", "solver", "iterations", "tolerance", "ls_iterations")
# The largest |qpos| gap (m or rad) over 1 s; achieved: 4.6e-8 (SO-100), 4.9e-8 (Ant), 1.1e-7 (trileg).
TRAJECTORY_TOLERANCE = 1e-6
WIDTHS = {int(mujoco.mjtJoint.mjJNT_FREE): (7, 6), int(mujoco.mjtJoint.mjJNT_BALL): (4, 3)}  # qpos, qvel sizes


@pytest.fixture(scope="module", params=list(MODELS))
def pair(request, tmp_path_factory) -> tuple[mujoco.MjModel, mujoco.MjModel, list[str]]:
    """The original model, the one imported from its export, and the import's warnings."""
    original = models_dir() / MODELS[request.param]
    imported = import_usd(export_model(original, tmp_path_factory.mktemp(request.param) / f"{request.param}.usd"))
    return mujoco.MjModel.from_xml_path(str(original)), imported.spec.compile(), imported.report.warnings


def test_the_export_imports_without_warnings(pair) -> None:
    assert pair[2] == []


def _matched_joints(original: mujoco.MjModel, imported: mujoco.MjModel) -> list[tuple[int, int]]:
    """(original, imported) joint ids, matched by name: every joint, the free joint included, keeps its name."""
    assert original.njnt == imported.njnt
    return [(j, imported.joint(original.joint(j).name).id) for j in range(original.njnt)]


def test_joints_come_back_with_names_types_and_ranges(pair) -> None:
    original, imported, _ = pair
    for j, k in _matched_joints(original, imported):
        assert imported.jnt_type[k] == original.jnt_type[j]
        if original.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            continue
        assert imported.jnt_limited[k] == original.jnt_limited[j]
        np.testing.assert_allclose(imported.jnt_range[k], original.jnt_range[j], atol=1e-6)
        dofs = imported.jnt_dofadr[k], original.jnt_dofadr[j]
        for field in ("armature", "damping", "frictionloss"):  # float32 in USD
            values = getattr(imported, f"dof_{field}")[dofs[0]], getattr(original, f"dof_{field}")[dofs[1]]
            assert values[0] == pytest.approx(values[1], rel=1e-6), field


def test_actuators_solver_options_and_margins_come_back(pair) -> None:
    original, imported, _ = pair
    index = _matched_actuators(original, imported)
    for field in ("gear", "gainprm", "biasprm", "ctrlrange", "ctrllimited"):
        np.testing.assert_allclose(
            getattr(imported, f"actuator_{field}")[index],
            getattr(original, f"actuator_{field}"),
            rtol=1e-6,
            atol=1e-9,
            err_msg=field,
        )
    for a, b in enumerate(index):  # an unlimited motor comes back limited to what its control range gives
        if original.actuator_forcelimited[a]:
            np.testing.assert_allclose(imported.actuator_forcerange[b], original.actuator_forcerange[a], rtol=1e-6)
    for option in SOLVER_OPTIONS:
        assert getattr(imported.opt, option) == getattr(original.opt, option), option
    margins = [
        sorted(
            (model.body(model.geom_bodyid[g]).name, model.geom_margin[g], model.geom_gap[g])
            for g in range(model.ngeom)
            if model.geom_contype[g] or model.geom_conaffinity[g]
        )
        for model in (original, imported)
    ]
    assert [m[0] for m in margins[1]] == [m[0] for m in margins[0]]
    np.testing.assert_allclose([m[1:] for m in margins[1]], [m[1:] for m in margins[0]], atol=1e-9)


def _matched_actuators(original: mujoco.MjModel, imported: mujoco.MjModel) -> np.ndarray:
    """For each original actuator, the imported one of the same name (the importer adds them in joint order)."""
    assert original.nu == imported.nu
    return np.array([imported.actuator(original.actuator(a).name).id for a in range(original.nu)], dtype=int)


def test_masses_and_inertias_agree_within_0_1_percent(pair) -> None:
    original, imported, _ = pair
    names = [[model.body(b).name for b in range(model.nbody)] for model in (original, imported)]
    assert names[0] == names[1]
    np.testing.assert_allclose(imported.body_mass, original.body_mass, rtol=1e-3)
    data = [mujoco.MjData(model) for model in (original, imported)]
    for model, datum in zip((original, imported), data, strict=True):
        mujoco.mj_kinematics(model, datum)
    for b in range(1, original.nbody):
        tensors = [_world_inertia(m, d, b) for m, d in zip((original, imported), data, strict=True)]
        np.testing.assert_allclose(tensors[1], tensors[0], atol=1e-3 * np.abs(tensors[0]).max())
        np.testing.assert_allclose(data[1].xipos[b], data[0].xipos[b], atol=1e-6)


def test_anchors_and_axes_agree_at_random_poses(pair) -> None:
    original, imported, _ = pair
    joints = _matched_joints(original, imported)
    rng = np.random.default_rng(7)
    data = mujoco.MjData(original), mujoco.MjData(imported)
    for _ in range(5):
        data[0].qpos[:] = original.qpos0
        for j, _k in joints:
            address, kind = original.jnt_qposadr[j], original.jnt_type[j]
            if kind == mujoco.mjtJoint.mjJNT_FREE:
                data[0].qpos[address : address + 7] = [*rng.uniform(-1, 1, 3), *_unit(rng.normal(size=4))]
            elif kind == mujoco.mjtJoint.mjJNT_BALL:
                data[0].qpos[address : address + 4] = _unit(rng.normal(size=4))
            else:
                low, high = original.jnt_range[j] if original.jnt_limited[j] else (-np.pi, np.pi)
                data[0].qpos[address] = rng.uniform(low, high)
        _copy_state(original, imported, joints, data[0], data[1])
        for model, datum in zip((original, imported), data, strict=True):
            mujoco.mj_kinematics(model, datum)
        for j, k in joints:
            np.testing.assert_allclose(data[1].xanchor[k], data[0].xanchor[j], atol=1e-6)
            np.testing.assert_allclose(data[1].xaxis[k], data[0].xaxis[j], atol=1e-6)


def _unit(vector: np.ndarray) -> np.ndarray:
    return vector / np.linalg.norm(vector)


def _world_inertia(model: mujoco.MjModel, data: mujoco.MjData, body: int) -> np.ndarray:
    frame = data.ximat[body].reshape(3, 3)
    return frame @ np.diag(model.body_inertia[body]) @ frame.T


def _copy_state(
    original: mujoco.MjModel,
    imported: mujoco.MjModel,
    joints: list[tuple[int, int]],
    source: mujoco.MjData,
    target: mujoco.MjData,
) -> None:
    """qpos and qvel of the original in the imported model's joint order (a joint's zero is qpos0 in both)."""
    for j, k in joints:
        width, dofs = WIDTHS.get(int(original.jnt_type[j]), (1, 1))
        qj, qk = original.jnt_qposadr[j], imported.jnt_qposadr[k]
        shift = (imported.qpos0[qk] - original.qpos0[qj]) if width == 1 else 0.0
        target.qpos[qk : qk + width] = source.qpos[qj : qj + width] + shift
        vj, vk = original.jnt_dofadr[j], imported.jnt_dofadr[k]
        target.qvel[vk : vk + dofs] = source.qvel[vj : vj + dofs]


def _max_trajectory_difference(original: mujoco.MjModel, imported: mujoco.MjModel) -> float:
    """Step both models for 1 s under the same random piecewise-constant controls; the largest |qpos| gap."""
    joints = _matched_joints(original, imported)
    index = _matched_actuators(original, imported)
    data = mujoco.MjData(original), mujoco.MjData(imported)
    rng = np.random.default_rng(3)
    worst = 0.0
    mirrored = mujoco.MjData(imported)
    for step in range(round(1.0 / original.opt.timestep)):
        if step % 50 == 0:
            ctrl = rng.uniform(*original.actuator_ctrlrange.T)
            data[0].ctrl[:] = data[1].ctrl[index] = ctrl
        for model, datum in zip((original, imported), data, strict=True):
            mujoco.mj_step(model, datum)
        _copy_state(original, imported, joints, data[0], mirrored)
        worst = max(worst, float(np.abs(mirrored.qpos - data[1].qpos).max()))
    return worst


def test_same_trajectory_under_the_same_controls(pair) -> None:
    original, imported, _ = pair
    assert _max_trajectory_difference(original, imported) < TRAJECTORY_TOLERANCE


def test_ball_joint_damping_and_a_margin_with_a_gap_come_back(tmp_path) -> None:
    """What the three robots do not have: a ball joint's passive properties, a slide's, and a gap (written as
    contactOffset = margin beside restOffset = margin - gap)."""
    xml = tmp_path / "passive.xml"
    xml.write_text("""<mujoco><worldbody><body name="a" pos="0 0 1">
      <joint name="slide" type="slide" damping="4" frictionloss="0.5" armature="0.2"/><geom size="0.1"/>
      <body name="b" pos="0.3 0 0"><joint name="ball" type="ball" damping="0.3" frictionloss="0.1"/>
        <geom size="0.05" margin="0.02" gap="0.005"/></body></body></worldbody></mujoco>""")
    original = mujoco.MjModel.from_xml_path(str(xml))
    imported = import_usd(export_model(xml, tmp_path / "passive.usda")).spec.compile()
    for field in ("dof_damping", "dof_frictionloss", "dof_armature", "geom_margin", "geom_gap"):
        np.testing.assert_allclose(getattr(imported, field), getattr(original, field), rtol=1e-6, err_msg=field)


def _touching(model: mujoco.MjModel) -> set[frozenset[tuple[str, int, tuple[float, ...]]]]:
    """The pairs of colliders that may touch (contype/conaffinity and body exclusions), each collider known by
    its body's name, its type and its position in the body."""

    def key(geom: int) -> tuple[str, int, tuple[float, ...]]:
        return (
            model.body(model.geom_bodyid[geom]).name,
            int(model.geom_type[geom]),
            tuple(model.geom_pos[geom].round(5)),
        )

    excluded = {frozenset((int(s) >> 16, int(s) & 0xFFFF)) for s in model.exclude_signature}
    colliders = [g for g in range(model.ngeom) if model.geom_contype[g] or model.geom_conaffinity[g]]
    pairs = set()
    for a, b in itertools.combinations(colliders, 2):
        bits = model.geom_contype[a] & model.geom_conaffinity[b] or model.geom_contype[b] & model.geom_conaffinity[a]
        if bits and frozenset((int(model.geom_bodyid[a]), int(model.geom_bodyid[b]))) not in excluded:
            pairs.add(frozenset((key(a), key(b))))
    return pairs


def test_which_colliders_may_touch_comes_back(tmp_path) -> None:
    """pick_place_mjx.xml's filtering (the cube touches only the table and the fingertips; five body pairs
    excluded) as CollisionGroups and FilteredPairsAPI, and back as contype/conaffinity bits and exclusions."""
    original_path = models_dir() / "so_arm100/pick_place_mjx.xml"
    stage = Usd.Stage.Open(str(export_model(original_path, tmp_path / "pick_place.usda")))
    groups = [prim for prim in stage.Traverse() if prim.IsA(UsdPhysics.CollisionGroup)]
    assert len(groups) == 4  # the classes (contype, conaffinity): table, arm, fingertips, cube
    imported = import_usd(Path(stage.GetRootLayer().realPath))
    assert imported.report.warnings == []
    original, model = mujoco.MjModel.from_xml_path(str(original_path)), imported.spec.compile()
    pairs = _touching(original)
    assert _touching(model) == pairs
    cube_touches = {name for pair in pairs for name, _, _ in pair if "cube" in {key[0] for key in pair}} - {"cube"}
    assert cube_touches == {"world", "fixed_jaw", "moving_jaw"}
