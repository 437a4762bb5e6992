"""The Isaac-convention tasks `isaac_ant_locomotion` and `isaac_trileg`, composed from terms.

Both follow Isaac's locomotion environment (IsaacGymEnvs `Ant`, Isaac Lab `Isaac-Ant-Direct-v0`):
the observation describes the root in a frame that turns with it, and the reward is the progress
towards a target 1000 m along +x plus alive, upright and heading bonuses, minus action, energy and
joint-limit costs. docs/tasks.md lists every term; docs/usd.md says where they differ from Isaac.
"""

from __future__ import annotations

from joshua_core.tasks import ActionSpec, TaskSpec, TermSpec

ROOT = {"body": "torso"}  # the floating root body (its free joint has no name in USD)
DOF_VEL_SCALE = 0.2  # Isaac's dof_vel_scale
CONTACT_FORCE_SCALE = 0.1  # Isaac's contact_force_scale
EPISODE_SECONDS = 15.0  # Isaac Lab's episode_length_s


def _observations(feet: tuple[str, ...]) -> tuple[TermSpec, ...]:
    """Isaac's observation, in its order, with the contact forces of the `feet` bodies (joints: every hinge)."""
    return (
        TermSpec("body_height", params={"body": "torso"}, name="torso_height"),
        TermSpec("base_lin_vel", params=ROOT),
        TermSpec("base_ang_vel", params={**ROOT, "scale": 1.0}),  # Isaac's angular_velocity_scale
        TermSpec("yaw_roll", params=ROOT),
        TermSpec("angle_to_target", params=ROOT),
        TermSpec("body_upright", params={"body": "torso"}, name="up_projection"),
        TermSpec("heading_projection", params=ROOT),
        TermSpec("joint_pos_normalized"),
        TermSpec("joint_vel", params={"scale": DOF_VEL_SCALE}),
        *(
            TermSpec("body_contact_force", params={"body": foot, "scale": CONTACT_FORCE_SCALE}, name=f"{foot}_force")
            for foot in feet
        ),
        TermSpec("last_action"),
    )


# Isaac's reward terms and weights (Isaac Lab AntEnvCfg; the joint-limit cost as IsaacGymEnvs' Ant)
_REWARDS = (
    TermSpec("progress_to_target", 1.0, ROOT, name="progress"),
    TermSpec("alive", 0.5),
    TermSpec("body_upright_above", 0.1, {"body": "torso", "min_upright": 0.93}, name="upright"),
    TermSpec("heading_reward", 0.5, {**ROOT, "threshold": 0.8}, name="move_to_target"),
    TermSpec("action_l2", -0.005, name="action_cost"),
    TermSpec("energy", -0.05, {"vel_scale": DOF_VEL_SCALE}, name="energy_cost"),
    TermSpec("joints_near_upper_limit", -0.1, {"threshold": 0.98}, name="joint_limit_cost"),
)

_METRICS = (
    TermSpec("progress_to_target", params=ROOT, name="progress"),
    TermSpec("heading_projection", params=ROOT, name="heading"),
)

ANT_FEET = ("front_left_shin", "front_right_shin", "back_shin", "right_back_shin")
ANT_FRAME_SKIP = 2  # 2 x 0.01 s: dt = 0.02 s (Isaac Lab: 2 x 1/120 s)

ISAAC_ANT_LOCOMOTION = TaskSpec(
    name="isaac_ant_locomotion",
    summary="Ant runs towards a far target along +x: Isaac's Ant observation (60), rewards and termination",
    model_path="isaac/ant.usd",
    frame_skip=ANT_FRAME_SKIP,
    episode_length=round(EPISODE_SECONDS / (0.01 * ANT_FRAME_SKIP)),
    observations=_observations(ANT_FEET),
    rewards=_REWARDS,
    terminations=(TermSpec("body_below", params={"body": "torso", "height": 0.31}, name="fallen"),),
    resets=(
        TermSpec("reset_joints_uniform", params={"scale": 0.2}),
        TermSpec("reset_qvel_normal", params={"scale": 0.1}),
    ),
    metrics=_METRICS,
    aliases=("AntEnv",),  # Isaac Lab's name: `from joshua_sb3 import AntEnv`
)

TRILEG_FEET = ("shin_1", "shin_2", "shin_3")
TRILEG_FRAME_SKIP = 5  # 5 x 0.004 s: dt = 0.02 s

ISAAC_TRILEG = TaskSpec(
    name="isaac_trileg",
    summary="Trileg keeps its balance and walks towards a far target along +x, in Isaac's locomotion form",
    model_path="isaac/trileg.usd",
    frame_skip=TRILEG_FRAME_SKIP,
    episode_length=round(EPISODE_SECONDS / (0.004 * TRILEG_FRAME_SKIP)),
    observations=_observations(TRILEG_FEET),
    rewards=_REWARDS,
    terminations=(
        TermSpec("body_below", params={"body": "torso", "height": 0.1}, name="fallen"),
        TermSpec("body_tilted", params={"body": "torso", "min_upright": 0.5}, name="tipped_over"),
    ),
    resets=(
        TermSpec("reset_joints_uniform", params={"scale": 0.05}),
        TermSpec("reset_qvel_normal", params={"scale": 0.05}),
    ),
    metrics=_METRICS,
    action=ActionSpec("offset", 0.6),
    aliases=("TrilegEnv",),  # named like AntEnv
)
