"""The deploy's control step for a policy with delta actions: each target moves from the one in force (from where
the arm is measured at the start), and the observation sees the targets in force, as in training."""

from __future__ import annotations

import math

import mujoco
import numpy as np
from google.protobuf import text_format
from numpy.typing import NDArray

from joshua_core.config_pb2 import TaskConfig
from joshua_core.plugins import PluginHost
from joshua_export import Observer
from joshua_mirror.controller import PolicyController
from joshua_mirror.joints import MirroredJoint

TASK = "so_arm100_reach"  # the task joshua deploy drives (its command is `target`), here with delta actions
DELTA = 'action { mode: "delta" scale: 0.05 } terms { name: "servo" term: "servo_error" kind: OBSERVATION }'


def mirrored_joints(model: mujoco.MjModel) -> list[MirroredJoint]:
    """One Float64 mapping per actuator of the model, without offsets."""
    joints = []
    for index in range(model.nu):
        joint = model.joint(int(model.actuator_trnid[index, 0]))
        low, high = joint.range if model.jnt_limited[joint.id] else (-math.inf, math.inf)
        joints.append(
            MirroredJoint(
                f"/encoder/{joint.name}",
                model.actuator(index).name,
                index,
                joint.name,
                int(joint.qposadr[0]),
                int(joint.dofadr[0]),
                0.0,
                float(low),
                float(high),
            )
        )
    return joints


def action_contract(observer: Observer) -> dict:
    """The contract's `action` part as joshua export writes it for the task."""
    task = observer.task
    terms = [
        {
            "actuator": observer.model.actuator(i).name,
            "scale": float(task.ctrl_scale[i]),
            "offset": float(task.ctrl_offset[i]),
            "ctrl_range": [float(task.ctrl_low[i]), float(task.ctrl_high[i])],
        }
        for i in range(task.action_size)
    ]
    return {"action": {"mode": task.spec.action.mode, "terms": terms}}


def test_delta_targets_move_from_the_targets_in_force_which_the_observation_sees() -> None:
    observer = Observer.load(TASK, None, PluginHost.discover(), text_format.Parse(DELTA, TaskConfig()))
    assert observer.task.delta_actions
    seen: list[NDArray[np.float32]] = []
    action = np.array([1.0, -1.0, 0.5, 0.0, 0.2, -0.4], np.float32)

    def policy(observation: NDArray[np.float32]) -> NDArray[np.float32]:
        seen.append(observation)
        return action

    joints = mirrored_joints(observer.model)
    controller = PolicyController(policy, action_contract(observer), observer, joints, max_step=1.0)
    measured = np.array([0.1, -0.3, 0.4, 0.9, 0.0, 0.3])
    velocities = np.zeros(6)
    first = controller.step(measured, velocities, np.zeros(3))
    np.testing.assert_allclose(first, measured + 0.05 * action, atol=1e-7)  # from where the arm is
    second = controller.step(measured, velocities, np.zeros(3))  # the arm has not moved yet
    np.testing.assert_allclose(second, first + 0.05 * action, atol=1e-7)
    # the `servo_error` slice, the last: targets in force - measured positions
    np.testing.assert_allclose(seen[0][-6:], 0.0, atol=1e-6)
    np.testing.assert_allclose(seen[1][-6:], first - measured, atol=1e-6)
    # the speed limit bounds the step from the targets in force, as for absolute targets
    slow = PolicyController(policy, action_contract(observer), observer, joints, max_step=0.01)
    np.testing.assert_allclose(
        slow.step(measured, velocities, np.zeros(3)), measured + 0.01 * np.sign(action), atol=1e-7
    )
