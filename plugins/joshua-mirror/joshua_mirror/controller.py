"""One control step of a deployed policy: measured joint positions -> observation -> action -> safe joint targets.

The observation is the task's own (`joshua_export.Observer` on the contract's robot model): encoder values
(+ the mirror mapping's offsets) are the joints' qpos, the difference of each joint's last two values over
their arrival times its qvel (RobotLink), the reach target the task's command and the previous action its
`last_action`, so the policy sees what it saw in training. The action becomes ctrl exactly as the contract
says (offset + scale x action, or for "delta" actions the target in force + scale x action, clipped to the
actuator's ctrl range; the targets in force are the observation's ctrl); each target is then clipped to its
joint's limits and moved at most `max_speed x period` from the previous target (from the measured position at
the first step and after a hold).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from joshua_mirror.joints import MirroredJoint

COMMAND = "target"  # the one task command joshua deploy sets (--target / --target-topic)


@dataclass
class Actuated:
    """One action entry of the contract: where its target goes and how it is bounded."""

    joint: MirroredJoint
    scale: float
    offset: float
    ctrl_low: float
    ctrl_high: float
    limited: int = 0  # steps whose target the joint limits (or the ctrl range) cut
    slowed: int = 0  # steps whose target the speed limit held back


class PolicyController:
    """Runs a policy on measured joint positions; keeps what the next step needs (previous state and action)."""

    def __init__(
        self, policy: Any, contract: dict[str, Any], observer: Any, joints: list[MirroredJoint], max_step: float
    ) -> None:
        self.policy = policy
        self.observer = observer
        self.joints = joints
        self.max_step = max_step  # largest target change per step (max speed x period)
        self.actuated = _actuated(contract, joints)
        self.delta = contract["action"]["mode"] == "delta"  # actions move the targets in force
        size = len(self.actuated)
        self.qpos = np.array(observer.task.initial_qpos, np.float64)  # unmapped (free) joints keep their keyframe
        self.previous: NDArray[np.float64] | None = None  # qpos of the last step
        self.last_action = np.zeros(size)
        self.prev_action = np.zeros(size)
        self.last_targets: NDArray[np.float64] | None = None

    def step(
        self, positions: NDArray[np.float64], velocities: NDArray[np.float64], command: Any
    ) -> NDArray[np.float64]:
        """The targets (one per action entry) for measured joint `positions` and `velocities` (sim units, in the
        order of `joints`) and the task's `target` command."""
        qpos = self.qpos.copy()
        qpos[[joint.qpos_address for joint in self.joints]] = positions
        qvel = np.zeros(self.observer.model.nv)
        qvel[[joint.dof_address for joint in self.joints]] = velocities
        prev_qpos = qpos if self.previous is None else self.previous
        measured = np.array([qpos[entry.joint.qpos_address] for entry in self.actuated])
        in_force = measured if self.last_targets is None else self.last_targets
        ctx = self.observer.context(
            qpos,
            qvel,
            commands={COMMAND: command},
            action=self.last_action,
            prev_action=self.prev_action,
            prev_qpos=prev_qpos,
            ctrl=in_force,
        )
        observation = self.observer.observe(ctx)
        action = np.clip(np.asarray(self.policy(observation), np.float32), -1.0, 1.0)
        targets = self._safe_targets(action, in_force)
        self.previous = qpos
        self.prev_action, self.last_action = self.last_action, action.astype(np.float64)
        self.last_targets = targets
        return targets

    def _safe_targets(self, action: NDArray[np.float32], in_force: NDArray[np.float64]) -> NDArray[np.float64]:
        """ctrl of the contract's mapping, clipped to the joint limits and to max_step from the targets in force
        (the last ones sent; the measured positions at the first step and after a hold)."""
        targets = np.empty(len(self.actuated))
        for index, entry in enumerate(self.actuated):
            base = in_force[index] if self.delta else entry.offset
            ctrl = base + entry.scale * float(action[index])
            bounded = min(max(ctrl, entry.ctrl_low, entry.joint.low), entry.ctrl_high, entry.joint.high)
            entry.limited += int(bounded != ctrl)
            low, high = in_force[index] - self.max_step, in_force[index] + self.max_step
            targets[index] = min(max(bounded, low), high)
            entry.slowed += int(targets[index] != bounded)
        return targets

    def hold_targets(self, positions: NDArray[np.float64]) -> NDArray[np.float64]:
        """Targets that keep the driven joints where they are measured (within their limits): a stop in place."""
        qpos = {joint.joint: position for joint, position in zip(self.joints, positions, strict=True)}
        self.last_targets = np.array(
            [min(max(qpos[entry.joint.joint], entry.joint.low), entry.joint.high) for entry in self.actuated]
        )
        return self.last_targets

    def restart(self) -> None:
        """Forget the last state and target (after a hold): the speed limit starts again from the measured
        position."""
        self.previous = None
        self.last_targets = None


def _actuated(contract: dict[str, Any], joints: list[MirroredJoint]) -> list[Actuated]:
    """The contract's action entries matched to the mapped joints (deploy checked that each has one)."""
    by_actuator = {joint.actuator: joint for joint in joints}
    result = []
    for term in contract["action"]["terms"]:
        low, high = term["ctrl_range"]  # None: not limited
        low, high = -math.inf if low is None else low, math.inf if high is None else high
        result.append(Actuated(by_actuator[term["actuator"]], term["scale"], term["offset"], low, high))
    return result


def unmapped_joints(model: mujoco.MjModel, joints: list[MirroredJoint]) -> list[str]:
    """Hinge and slide joints of the policy's model that no mapping measures (the observation needs them all)."""
    mapped = {joint.joint for joint in joints}
    kinds = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
    return [
        model.joint(index).name
        for index in range(model.njnt)
        if int(model.jnt_type[index]) in kinds and model.joint(index).name not in mapped
    ]
