"""The tabletop arms' tasks: reach and pick-and-place, each written once as a function of the arm."""

from __future__ import annotations

from dataclasses import dataclass

from joshua_core.tasks import ActionSpec, TaskSpec, TermSpec


@dataclass(frozen=True)
class Arm:
    """A tabletop arm the reach and pick-and-place tasks are written for: the arms share the tasks' terms, sites
    (`gripper`, the jaw pads' touch sensors), `home` keyframe and table scene, and differ in these."""

    key: str  # the tasks' name prefix, and its models' folder under models/ (scene.xml, pick_place.xml)
    title: str  # the arm's name in the tasks' summaries
    joints: tuple[str, ...]  # the arm's five joints from the base out, then the jaw's


SO_ARM100 = Arm("so_arm100", "SO-ARM100", tuple(f"joint_{i}" for i in range(1, 7)))
SO101 = Arm("so101", "SO-101", ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper"))

_REACH_TARGET = {"name": "target", "low": (0.15, -0.15, 0.05), "high": (0.3, 0.15, 0.25)}


def reach(arm: Arm) -> TaskSpec:
    """`arm` moves its gripper site to a random target in front of it."""
    return TaskSpec(
        name=f"{arm.key}_reach",
        summary=f"{arm.title} moves its gripper site to a random target in front of it",
        model_path=f"{arm.key}/scene.xml",
        frame_skip=10,  # 10 x 2 ms: dt = 0.02 s (50 Hz control)
        episode_length=100,
        keyframe="home",
        commands={"target": 3},
        observations=(
            TermSpec("joint_pos"),
            TermSpec("joint_vel"),
            TermSpec("site_to_command", params={"site": "gripper", "name": "target"}, name="target_offset"),
            TermSpec("command", params={"name": "target"}, name="target"),
            TermSpec("last_action"),
        ),
        rewards=(
            TermSpec("site_command_distance", -1.0, {"site": "gripper", "name": "target"}, name="distance"),
            TermSpec("site_command_tanh", 0.5, {"site": "gripper", "name": "target", "std": 0.05}, name="near"),
            TermSpec("action_rate_l2", -0.005, name="action_rate"),
        ),
        resets=(
            TermSpec("reset_joints_uniform", params={"scale": 0.1}),
            TermSpec("sample_command_uniform", params=_REACH_TARGET, name="target"),
        ),
        metrics=(TermSpec("site_command_distance", params={"site": "gripper", "name": "target"}, name="distance"),),
        action=ActionSpec("offset", 1.0),
    )


_CUBE_HALF = 0.015
_GOAL = {"name": "goal", "low": (0.15, 0.05, _CUBE_HALF), "high": (0.25, 0.15, _CUBE_HALF)}
_AT_GOAL = {"body": "cube", "name": "goal"}
_PADS = {"first": "gripper_touch_fixed", "second": "gripper_touch_moving"}  # the jaw pads' touch sensors


def pick_place(arm: Arm) -> TaskSpec:
    """`arm` picks up the cube and places it on a random goal on the table."""
    return TaskSpec(
        name=f"{arm.key}_pick_place",
        summary=f"{arm.title} picks up the cube and places it on a random goal on the table",
        model_path=f"{arm.key}/pick_place.xml",
        frame_skip=2,  # 2 x 10 ms (pick_place.xml): dt = 0.02 s (50 Hz control)
        episode_length=400,
        keyframe="home",
        commands={"goal": 3},
        observations=(
            TermSpec("joint_pos", params={"joints": arm.joints}),
            TermSpec("joint_vel", params={"joints": arm.joints}),
            TermSpec("servo_error"),  # where the targets are: the delta actions move them
            TermSpec("site_to_body", params={"site": "gripper", "body": "cube"}, name="cube_offset"),
            TermSpec("body_to_command", params={"body": "cube", "name": "goal"}, name="goal_offset"),
            TermSpec("body_pos", params={"body": "cube"}, name="cube_position"),
            # saturated at 100 N (a grasp reads ~46 N): contact spikes would inflate the normaliser's variance
            # (see terms.sensor)
            TermSpec("sensor", params={"sensor": "gripper_touch_fixed", "saturation": 100.0}, name="touch_fixed"),
            TermSpec("sensor", params={"sensor": "gripper_touch_moving", "saturation": 100.0}, name="touch_moving"),
            TermSpec("last_action"),
        ),
        rewards=(
            # std 0.1: the gripper starts 0.11-0.17 m from the cube, where std 0.05 paid almost nothing (< 0.02)
            TermSpec("site_body_tanh", 1.0, {"site": "gripper", "body": "cube", "std": 0.1}, name="reach"),
            # the cube between both pads, not any touch of both: a press on the cube's top touches both pads too,
            # and paid policies that pressed the cube into the table (test_pick_place_scripted.py)
            TermSpec("body_pinched", 0.5, {"body": "cube", **_PADS, "threshold": 0.05, "radius": 0.02}, name="grasp"),
            TermSpec("body_height_above", 1.0, {"body": "cube", "height": 0.04}, name="lift"),
            # while the gripper is at the cube: a reward for a cube lying near its goal paid the policy for leaving
            # it alone, and one only for a lifted cube paid nothing until a grasp and a lift were found together
            TermSpec(
                "pushed_command_tanh", 2.0, {**_AT_GOAL, "site": "gripper", "radius": 0.05, "std": 0.1}, name="place"
            ),
            # the same, coarse (std 0.3, as Isaac Lab's Lift): it pays across the whole table, so carrying the cube
            # toward the goal earns from the first grasp, where runs otherwise settled on holding it
            TermSpec(
                "pushed_command_tanh", 2.0, {**_AT_GOAL, "site": "gripper", "radius": 0.05, "std": 0.3}, name="carry"
            ),
            TermSpec("body_command_within", 5.0, {"body": "cube", "name": "goal", "radius": 0.02}, name="at_goal"),
            # the cube let go at its goal: otherwise a cube at its goal pays as much held as released, and runs held
            # placed cubes until they lost them; weight 3 makes letting go clearly pay
            TermSpec(
                "body_released_at_command",
                3.0,
                {**_AT_GOAL, "radius": 0.02, **_PADS, "threshold": 0.05},
                name="released",
            ),
            TermSpec("action_rate_l2", -0.005, name="action_rate"),
        ),
        terminations=(TermSpec("body_below", params={"body": "cube", "height": -0.05}, name="cube_dropped"),),
        resets=(
            TermSpec("reset_joints_uniform", params={"scale": 0.05, "joints": arm.joints[:3]}),
            TermSpec(
                "reset_free_joint_xy", params={"joint": "cube_joint", "low": (0.17, -0.12), "high": (0.25, -0.04)}
            ),
            TermSpec("sample_command_uniform", params=_GOAL, name="goal"),
        ),
        metrics=(
            TermSpec("body_command_within", params={"body": "cube", "name": "goal", "radius": 0.02}, name="success"),
            TermSpec("body_command_distance", params={"body": "cube", "name": "goal"}, name="distance"),
        ),
        # The targets move by at most 0.05 rad per step (2.5 rad/s; the STS3215 servos turn at up to 4.7): random
        # actions wander smoothly instead of throwing the arm across its range every step, as absolute targets
        # (offset mode, scale 2 to reach every goal) did.
        action=ActionSpec("delta", 0.05),
    )


ARMS = (SO_ARM100, SO101)
