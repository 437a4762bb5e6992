"""The mirrored joints: each `TopicMapping` checked against the model and resolved to qpos/ctrl addresses."""

from __future__ import annotations

import difflib
import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco

from joshua_core.config_pb2 import SimulationConfig
from joshua_core.errors import ConfigError
from joshua_core.options import options_of
from joshua_mirror import options_pb2
from joshua_mirror.names import check_config_names
from joshua_mirror.options_pb2 import MirrorOptions, TopicMapping

MAPPINGS_FIELD = "simulation.mirror_topic_mappings.mappings"


def topic_mappings(config: SimulationConfig) -> Sequence[TopicMapping]:
    """The config's mappings (`simulation.mirror_topic_mappings`, this plugin's option); none when it sets none."""
    return options_of(config, options_pb2.mirror_topic_mappings).mappings


@dataclass(frozen=True)
class MirroredJoint:
    """One mapping resolved against the model: where its values come from and where they go."""

    source: str  # the ROS topic (FLOAT64) or the name in the JointState message (JOINT_STATE)
    actuator: str
    actuator_id: int
    joint: str
    qpos_address: int
    dof_address: int
    offset: float  # sim joint position = encoder value + offset
    low: float  # the joint's range (-inf, inf when the joint is not limited)
    high: float
    command_topic: str = ""  # Float64 topic of the target sent to the real joint (simulation.mirror.command_topics)

    def to_sim(self, value: float) -> float:
        return value + self.offset


def resolve_joints(
    model: mujoco.MjModel, mappings: Sequence[TopicMapping], options: MirrorOptions, *, by_topics: bool = True
) -> list[MirroredJoint]:
    """Check every mapping against the model and the options, reporting all problems at once as ConfigError; then
    the config's ROS names (`check_config_names`). Without `by_topics` (an arm read through LeRobot) the topics
    are neither needed nor checked, so no ROS 2 is needed either."""
    if not mappings:
        raise ConfigError(f"{MAPPINGS_FIELD} is empty: the MIRROR mode needs at least one topic -> actuator mapping")
    problems: list[str] = []
    joints: list[MirroredJoint] = []
    by_float64 = by_topics and options.message_type == MirrorOptions.FLOAT64
    actuator_names = [model.actuator(i).name for i in range(model.nu)]
    for index, mapping in enumerate(mappings):
        where = f"{MAPPINGS_FIELD}[{index}]"
        joint, problem = _resolve(model, mapping, actuator_names, options)
        if problem:
            problems.append(f"{where}: {problem}")
        elif by_float64 and not mapping.ros_topic:
            problems.append(f"{where}: ros_topic is empty")
        elif joint is not None:
            joints.append(joint)
    for label, values in (
        ("actuator", [m.mujoco_actuator for m in mappings if m.mujoco_actuator]),
        ("joint", [joint.joint for joint in joints]),
        ("ros_topic" if by_float64 else "JointState name", [joint.source for joint in joints] if by_topics else []),
    ):
        for value, count in Counter(values).items():
            if count > 1:
                problems.append(f"{MAPPINGS_FIELD}: {label} '{value}' is mapped {count} times")
    mapped = {m.mujoco_actuator for m in mappings}
    for field_name in ("joint_state_names", "command_topics"):
        unknown_names = sorted(set(getattr(options, field_name)) - mapped)
        if unknown_names:
            problems.append(
                f"simulation.mirror.{field_name} names actuators that are not mapped: {', '.join(unknown_names)}"
            )
    if problems:
        raise ConfigError("the mirror mapping does not fit the model:\n- " + "\n- ".join(problems))
    if not by_topics:
        return joints
    topics = {f"{MAPPINGS_FIELD}[{index}].ros_topic": joint.source for index, joint in enumerate(joints) if by_float64}
    topics |= {f"simulation.mirror.command_topics['{j.actuator}']": j.command_topic for j in joints if j.command_topic}
    check_config_names(options, topics)
    return joints


def _resolve(
    model: mujoco.MjModel, mapping: TopicMapping, actuator_names: list[str], options: MirrorOptions
) -> tuple[MirroredJoint | None, str | None]:
    """The resolved joint, or the problem with this mapping."""
    name = mapping.mujoco_actuator
    if not name:
        return None, "mujoco_actuator is empty"
    actuator_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
    if actuator_id < 0:
        close = difflib.get_close_matches(name, actuator_names, n=3)
        hint = f" Did you mean: {', '.join(close)}?" if close else ""
        return None, f"no actuator '{name}' in the model.{hint} Actuators: {', '.join(actuator_names) or 'none'}"
    if int(model.actuator_trntype[actuator_id]) != int(mujoco.mjtTrn.mjTRN_JOINT):
        return None, f"actuator '{name}' does not drive a joint, so there is no joint position to mirror"
    joint_id = int(model.actuator_trnid[actuator_id, 0])
    if int(model.jnt_type[joint_id]) not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
        return None, f"actuator '{name}' drives joint '{model.joint(joint_id).name}', which is not a hinge or slide"
    if options.apply != MirrorOptions.KINEMATIC and not _is_position_actuator(model, actuator_id):
        return None, (
            f"actuator '{name}' is not a position actuator, so its ctrl is not a joint position; "
            "use simulation.mirror.apply: KINEMATIC"
        )
    low, high = (float(v) for v in model.jnt_range[joint_id]) if model.jnt_limited[joint_id] else (-math.inf, math.inf)
    joint_name = model.joint(joint_id).name
    if options.message_type == MirrorOptions.FLOAT64:
        source = mapping.ros_topic
    else:
        source = options.joint_state_names.get(name) or joint_name
    mirrored = MirroredJoint(
        source=source,
        actuator=name,
        actuator_id=actuator_id,
        joint=joint_name,
        qpos_address=int(model.jnt_qposadr[joint_id]),
        dof_address=int(model.jnt_dofadr[joint_id]),
        offset=float(mapping.offset),
        low=low,
        high=high,
        command_topic=options.command_topics.get(name, ""),
    )
    return mirrored, None


def _is_position_actuator(model: mujoco.MjModel, actuator_id: int) -> bool:
    """ctrl is a joint position target: force = kp * (ctrl - q) - kv * qdot, i.e. gain kp and bias (0, -kp, -kv)."""
    kp = model.actuator_gainprm[actuator_id, 0]
    return (
        int(model.actuator_gaintype[actuator_id]) == int(mujoco.mjtGain.mjGAIN_FIXED)
        and int(model.actuator_biastype[actuator_id]) == int(mujoco.mjtBias.mjBIAS_AFFINE)
        and kp > 0
        and model.actuator_biasprm[actuator_id, 0] == 0
        and model.actuator_biasprm[actuator_id, 1] == -kp
    )
