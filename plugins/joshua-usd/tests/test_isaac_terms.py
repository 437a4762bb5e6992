"""The Isaac tasks' terms on known states, against values computed here independently (MuJoCo's own
rotation functions, limits read from the model): torso height, frame velocities, yaw and roll, the
target terms, up projection of a tilted torso, normalised joints and the joint-limit and energy costs."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from joshua_core.errors import ConfigError
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_core.tasks import BoundTerm, Task, TermContext, TermSpec, build_task
from joshua_usd.tasks.specs import ISAAC_ANT_LOCOMOTION

TILT = 0.3  # rad about the world x axis
YAW = math.pi / 2  # then turned to face +y


@pytest.fixture(scope="module")
def ant() -> tuple[Task, mujoco.MjModel]:
    model = mujoco.MjModel.from_xml_path(str(resolve_data_path("ant/ant.xml")))
    return build_task("isaac_ant_locomotion", model, PluginHost.discover()), model


def terms(task: Task) -> dict[str, BoundTerm]:
    every = task.observation_terms + task.reward_terms + task.termination_terms + task.metric_terms
    return {term.name: term for term in every}


def state(model: mujoco.MjModel, quat: np.ndarray, velocity: np.ndarray) -> mujoco.MjData:
    """The Ant with its torso at (0.1, 0.2, 0.6) in orientation `quat` moving at `velocity` (world), hip_1 at
    its upper limit, ankle_1 at its middle, the other joints at their lower limit."""
    data = mujoco.MjData(model)
    data.qpos[:7] = [0.1, 0.2, 0.6, *quat]
    for i in range(1, model.njnt):
        low, high = model.jnt_range[i]
        data.qpos[model.jnt_qposadr[i]] = {"hip_1": high, "ankle_1": (low + high) / 2}.get(model.joint(i).name, low)
    data.qvel[:3] = velocity
    data.qvel[3:6] = [0.5, -0.2, 0.1]
    data.qvel[6:] = np.arange(1.0, 9.0)
    mujoco.mj_forward(model, data)
    return data


def context(task: Task, data: mujoco.MjData, prev_qpos: np.ndarray, action: np.ndarray) -> TermContext:
    return TermContext(
        xp=np, dt=task.dt, qpos=data.qpos[None].copy(), qvel=data.qvel[None].copy(), prev_qpos=prev_qpos[None],
        xpos=data.xpos[None].copy(), xquat=data.xquat[None].copy(), cfrc_ext=data.cfrc_ext[None].copy(),
        action=action[None], prev_action=np.zeros((1, task.action_size)),
    )  # fmt: skip


def quaternion(yaw: float, roll: float) -> np.ndarray:
    """Yaw about z after roll about x (x-y-z Euler angles, as Isaac's get_euler_xyz reads them)."""
    turn, tilt = np.zeros(4), np.zeros(4)
    mujoco.mju_axisAngle2Quat(turn, [0, 0, 1], yaw)
    mujoco.mju_axisAngle2Quat(tilt, [1, 0, 0], roll)
    result = np.zeros(4)
    mujoco.mju_mulQuat(result, turn, tilt)
    return result


def test_root_frame_terms_of_a_turned_tilted_torso(ant: tuple[Task, mujoco.MjModel]) -> None:
    task, model = ant
    quat, velocity = quaternion(YAW, TILT), np.array([1.0, 0.5, -0.2])
    data = state(model, quat, velocity)
    prev_qpos = data.qpos.copy()
    prev_qpos[:2] -= [0.05, 0.0]  # moved 5 cm along +x during the step
    ctx = context(task, data, prev_qpos, np.zeros(8))
    by_name = terms(task)
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, quat)
    rotation = rotation.reshape(3, 3)
    np.testing.assert_allclose(by_name["torso_height"](ctx), [0.6])
    np.testing.assert_allclose(by_name["base_lin_vel"](ctx), [rotation.T @ velocity], atol=1e-12)
    np.testing.assert_allclose(by_name["base_ang_vel"](ctx), [[0.5, -0.2, 0.1]])
    np.testing.assert_allclose(by_name["yaw_roll"](ctx), [[YAW, TILT]], atol=1e-12)
    np.testing.assert_allclose(by_name["up_projection"](ctx), [math.cos(TILT)], atol=1e-12)
    # facing +y, the target 1000 m along +x is a quarter turn to the right
    bearing = math.atan2(-0.2, 1000 - 0.1)
    np.testing.assert_allclose(by_name["angle_to_target"](ctx), [bearing - YAW], atol=1e-12)
    heading = rotation[:, 0] @ [math.cos(bearing), math.sin(bearing), 0.0]
    np.testing.assert_allclose(by_name["heading_projection"](ctx), [heading], atol=1e-12)
    np.testing.assert_allclose(by_name["move_to_target"](ctx), [heading / 0.8], atol=1e-12)
    assert by_name["upright"](ctx)[0] == 1.0  # up projection cos(0.3) = 0.955 > 0.93
    distance = lambda q: math.hypot(1000 - q[0], 0 - q[1])  # noqa: E731
    np.testing.assert_allclose(by_name["progress"](ctx), [(distance(prev_qpos) - distance(data.qpos)) / 0.02])


def test_upright_bonus_needs_up_projection_above_0_93(ant: tuple[Task, mujoco.MjModel]) -> None:
    task, model = ant
    for roll, bonus in ((0.3, 0.1), (0.4, 0.0)):  # cos 0.3 = 0.955, cos 0.4 = 0.921
        ctx = context(task, state(model, quaternion(0.0, roll), np.zeros(3)), np.zeros(model.nq), np.zeros(8))
        by_name = terms(task)
        assert by_name["upright"].weight * by_name["upright"](ctx)[0] == pytest.approx(bonus)


def test_joint_terms_use_the_model_limits_and_energy_pairs_actions_with_driven_joints(
    ant: tuple[Task, mujoco.MjModel],
) -> None:
    task, model = ant
    data = state(model, quaternion(0.0, 0.0), np.zeros(3))
    action = np.linspace(-1.0, 1.0, 8)
    ctx = context(task, data, data.qpos.copy(), action)
    by_name = terms(task)
    hinges = range(1, model.njnt)  # every joint but the free one, in model order
    expected = [{"hip_1": 1.0, "ankle_1": 0.0}.get(model.joint(j).name, -1.0) for j in hinges]
    np.testing.assert_allclose(by_name["joint_pos_normalized"](ctx), [expected], atol=1e-12)
    np.testing.assert_allclose(by_name["joint_vel"](ctx), [0.2 * data.qvel[6:]])
    assert by_name["joint_limit_cost"](ctx)[0] == 1.0  # only hip_1 is past 0.98 towards its upper limit
    # ant.xml lists its motors from leg 4 on: action i meets the velocity of the joint motor i drives
    driven = [model.jnt_dofadr[model.actuator_trnid[i, 0]] for i in range(model.nu)]
    assert driven != sorted(driven)
    energy = np.sum(np.abs(action * data.qvel[driven] * 0.2))
    np.testing.assert_allclose(by_name["energy_cost"](ctx), [energy])
    np.testing.assert_allclose(by_name["action_cost"](ctx), [np.sum(action**2)])


def test_foot_forces_are_the_feet_contact_wrenches_times_0_1(ant: tuple[Task, mujoco.MjModel]) -> None:
    task, model = ant
    data = mujoco.MjData(model)
    data.qpos[2] = 0.06  # legs stretched out, pressed into the floor
    mujoco.mj_forward(model, data)
    mujoco.mj_rnePostConstraint(model, data)
    ctx = context(task, data, data.qpos.copy(), np.zeros(8))
    by_name = terms(task)
    feet = ("front_left_shin", "front_right_shin", "back_shin", "right_back_shin")
    forces = np.concatenate([by_name[f"{foot}_force"](ctx)[0] for foot in feet])
    np.testing.assert_allclose(forces, 0.1 * np.concatenate([data.cfrc_ext[model.body(f).id] for f in feet]))
    assert np.abs(forces).max() > 0.1
    assert by_name["fallen"](ctx)[0]  # torso below 0.31 m


def test_observation_layout_is_isaacs() -> None:
    model = mujoco.MjModel.from_xml_path(str(resolve_data_path("trileg/trileg.xml")))
    trileg = build_task("isaac_trileg", model, PluginHost.discover())
    names = [term.name for term in trileg.observation_terms]
    assert names[:7] == [
        "torso_height", "base_lin_vel", "base_ang_vel", "yaw_roll", "angle_to_target", "up_projection",
        "heading_projection",
    ]  # fmt: skip
    assert trileg.observation_size == 1 + 3 + 3 + 2 + 1 + 1 + 1 + 6 + 6 + 3 * 6 + 6


def test_root_terms_need_the_floating_body(ant: tuple[Task, mujoco.MjModel]) -> None:
    task, model = ant
    body = next(term for term in task.observation_terms if term.name == "base_lin_vel").params["body"]
    assert (body.free_qpos_adr, body.free_dof_adr) == (0, 0)  # found by the body, not by the joint's name
    thigh = TermSpec("base_lin_vel", params={"body": "back_thigh"})
    spec = dataclasses.replace(ISAAC_ANT_LOCOMOTION, observations=(thigh,))
    with pytest.raises(ConfigError, match="body 'back_thigh' has no free joint"):
        build_task(spec, model, PluginHost.discover())
