"""The legged robots' locomotion tasks: the Ant (Gymnasium Ant-v5's task) and the three-legged walker."""

from __future__ import annotations

from joshua_core.tasks import ActionSpec, TaskSpec, TermSpec

_ANT_HEALTHY = {"joint": "root", "min_z": 0.2, "max_z": 1.0}

ANT_LOCOMOTION = TaskSpec(
    name="ant_locomotion",
    summary="Ant quadruped runs forward: Gymnasium Ant-v5 observation, reward, termination and reset",
    model_path="ant/ant.xml",
    frame_skip=5,  # 5 x 0.01 s: dt = 0.05 s, as Ant-v5
    episode_length=1000,
    observations=(
        TermSpec("qpos", params={"start": 2}),
        TermSpec("qvel"),
        TermSpec("contact_forces", params={"limit": 1.0}),
    ),
    rewards=(
        TermSpec("forward_velocity", 1.0, {"joint": "root", "axis": 0}, name="forward"),
        TermSpec("healthy", 1.0, _ANT_HEALTHY, name="healthy"),
        TermSpec("action_l2", -0.5, name="ctrl_cost"),
        TermSpec("contact_force_l2", -5e-4, {"limit": 1.0}, name="contact_cost"),
    ),
    terminations=(TermSpec("unhealthy", params=_ANT_HEALTHY),),
    resets=(
        TermSpec("reset_qpos_uniform", params={"scale": 0.1}),
        TermSpec("reset_qvel_normal", params={"scale": 0.1}),
    ),
    metrics=(TermSpec("forward_velocity", params={"joint": "root", "axis": 0}, name="x_velocity"),),
)

_TRILEG_HEALTHY = {"joint": "root", "min_z": 0.1, "max_z": 0.5}

TRILEG_LOCOMOTION = TaskSpec(
    name="trileg_locomotion",
    summary="Three-legged walker keeps its balance and walks forward (+x)",
    model_path="trileg/trileg.xml",
    frame_skip=5,  # 5 x 0.004 s: dt = 0.02 s
    episode_length=1000,
    observations=(
        TermSpec("qpos", params={"start": 2}),
        TermSpec("qvel"),
        TermSpec("last_action"),
    ),
    rewards=(
        TermSpec("forward_velocity", 1.0, {"joint": "root", "axis": 0}, name="forward"),
        TermSpec("healthy", 0.5, _TRILEG_HEALTHY, name="healthy"),
        TermSpec("body_upright", 0.5, {"body": "torso"}, name="upright"),
        TermSpec("action_l2", -0.01, name="ctrl_cost"),
        TermSpec("action_rate_l2", -0.01, name="action_rate"),
    ),
    terminations=(
        TermSpec("unhealthy", params=_TRILEG_HEALTHY),
        TermSpec("body_tilted", params={"body": "torso", "min_upright": 0.5}, name="tipped_over"),
    ),
    resets=(
        TermSpec("reset_joints_uniform", params={"scale": 0.05}),
        TermSpec("reset_qvel_normal", params={"scale": 0.05}),
    ),
    metrics=(TermSpec("forward_velocity", params={"joint": "root", "axis": 0}, name="x_velocity"),),
    action=ActionSpec("offset", 0.6),
)
