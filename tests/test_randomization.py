"""Domain randomization (joshua_core.tasks.randomization) on the CPU backend: events from the config are
checked when the task is built, and each simulation runs with its own drawn values; desynchronised
first episodes."""

from __future__ import annotations

import json

import numpy as np
import pytest
from google.protobuf import text_format

from joshua_core.config import load_preset
from joshua_core.config_pb2 import TaskConfig
from joshua_core.errors import ConfigError
from joshua_core.options import LENIENT
from joshua_mujoco import make_vector_env

TASK = "so_arm100_pick_place"
NO_RESET_NOISE = 'terms { name: "reset_joints_uniform" weight: 0 } terms { name: "reset_free_joint_xy" weight: 0 } '


def event(name: str, term: str, mode: str = "RESET", interval: int = 0, **params: str) -> str:
    listed = " ".join(
        f"params {{ key: {json.dumps(key)} value: {json.dumps(value)} }}" for key, value in params.items()
    )
    return f'events {{ name: "{name}" term: "{term}" mode: {mode} interval_steps: {interval} {listed} }} '


def env_with(text: str, num_envs: int = 4, **options):
    return make_vector_env(
        TASK, num_envs, seed=1, nthread=1, task_config=text_format.Parse(text, TaskConfig()), **options
    )


def test_the_randomized_preset_builds_and_draws_within_its_ranges() -> None:
    config = load_preset("so_arm100_pick_place_mjx_dr", LENIENT).message.training.task_config
    env = make_vector_env(TASK, 16, seed=0, nthread=1, task_config=config)
    simulation, defaults = env.simulation, env.task.defaults
    cube = env.simulation.model.body("cube").id
    ratio = simulation.physics.batch.expanded("body_mass")[:, cube] / defaults["body_mass"][cube]
    assert 0.7 <= ratio.min() < ratio.max() <= 1.3
    kp = simulation.physics.batch.expanded("actuator_gainprm")[:, :, 0] / defaults["actuator_gainprm"][:, 0]
    assert 0.9 <= kp.min() < kp.max() <= 1.1
    assert set(np.unique(simulation.params["action_delay"])) == {0, 1}


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            event("m", "randomize_body_mass", bodies='["cub"]', range="[0.7, 1.3]"),
            "no body named 'cub'. Did you mean: cube",
        ),
        (event("m", "randomize_body_mass", bodies='["cube"]', range="[1.3, 0.7]"), "range \\[1.3, 0.7\\] is inverted"),
        (event("m", "randomize_body_mass", bodies='["cube"]', range='[0.7, "inf"]'), "range of two numbers"),
        (event("m", "randomize_body_mass", bodies='["cube"]', range="[0.7, 1e999]"), "is not finite"),
        (event("f", "randomize_geom_friction", geoms='["fixed_pads"]', range="[0.8, 1.2]"), "Did you mean: fixed_pad"),
        (event("g", "randomize_actuator_gains", actuators='["joint_1"]'), "no actuator named 'joint_1'"),
        (event("d", "randomize_joint_damping", range="[-1, 1]", distribution='"log_uniform"'), "must be positive"),
        (event("d", "randomize_joint_damping", range="[1, 2]", distribution='"gauss"'), "unknown distribution 'gauss'"),
        (event("n", "observation_noise", "INTERVAL", 0), "needs interval_steps of at least 1"),
        (event("n", "observation_noise", "MODE_UNSPECIFIED"), "set `mode` to RESET or INTERVAL"),
        (event("a", "action_delay", range="[0, 1.5]"), "whole numbers of steps"),
        (
            event("n", "observation_noise", "INTERVAL", 1, terms='["cube_ofset"]'),
            "event 'n', parameter 'terms': the task has no observation term 'cube_ofset'. Did you mean: cube_offset",
        ),
        (event("n", "observation_noise", "INTERVAL", 1, terms='"cube_offset"'), "a list of observation term names"),
        (event("x", "randomize_mass"), "randomize_body_mass"),
    ],
)
def test_bad_events_fail_when_the_task_is_built(text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        env_with(text)


def test_mass_changes_recompute_the_derived_inverse_weights() -> None:
    env = env_with(event("m", "randomize_body_mass", bodies='["cube"]', range="[0.5, 2.0]"))
    batch, cube = env.simulation.physics.batch, env.simulation.model.body("cube").id
    mass = batch.expanded("body_mass")[:, cube]
    # the free cube: mj_setConst's translational inverse weight is 1 / mass
    np.testing.assert_allclose(batch.expanded("body_invweight0")[:, cube, 0], 1.0 / mass, rtol=1e-9)
    inertia = batch.expanded("body_inertia")[:, cube]
    ratio = mass / env.task.defaults["body_mass"][cube]
    np.testing.assert_allclose(inertia / env.task.defaults["body_inertia"][cube], np.repeat(ratio[:, None], 3, axis=1))


@pytest.mark.parametrize("mode", ["offset", "delta"])
def test_action_delay_feeds_the_previous_action_and_offsets_shift_the_targets(mode: str) -> None:
    text = (
        NO_RESET_NOISE
        + event("a", "action_delay", range="[1, 1]")
        + event("o", "randomize_joint_offset", range="[0.05, 0.05]")
    )
    env = env_with(text + f'action {{ mode: "{mode}" }}', 2)
    task, ctrl = env.task, env.simulation.ctrl
    first, second = np.full((2, 6), 0.1), np.full((2, 6), -0.2)
    zero_action = np.clip(task.ctrl_offset + 0.05, task.ctrl_low, task.ctrl_high)
    np.testing.assert_allclose(ctrl, np.tile(zero_action, (2, 1)))  # an episode starts at home + offset
    env.step(first)
    np.testing.assert_allclose(ctrl, np.tile(zero_action, (2, 1)))  # the zero action of before the episode
    env.step(second)
    moved = task.ctrl_scale * first + (zero_action if mode == "delta" else task.ctrl_offset + 0.05)
    np.testing.assert_allclose(ctrl, np.clip(moved, task.ctrl_low, task.ctrl_high))


def test_interval_events_fire_every_n_steps_and_pushes_last_one_step() -> None:
    text = NO_RESET_NOISE + event("p", "push_body", "INTERVAL", 5, body="cube", force="[2.0, 2.0]")
    text += event("n", "observation_noise", "INTERVAL", 1, std="0.1")
    env = env_with(text, 2)
    quiet = env_with(NO_RESET_NOISE, 2)
    cube = env.simulation.model.body("cube").id
    pushed = []
    for _ in range(10):
        noisy, *_ = env.step(np.zeros((2, 6)))
        clean, *_ = quiet.step(np.zeros((2, 6)))
        pushed.append(env.simulation.params["xfrc_applied"][:, cube, :3].copy())
        assert 0.03 < np.std(noisy - clean) < 0.3  # fresh noise of std 0.1 on every step
    active = [step for step, force in enumerate(pushed, start=1) if (force == 2.0).all()]
    assert active == [5, 10]  # drawn on steps 5 and 10, applied during the next one, then cleared
    cube_x = env.simulation.qpos[:, 6 + 0]
    assert (cube_x > quiet.simulation.qpos[:, 6] + 1e-4).all()  # 2 N along +x for 0.02 s moved the cube


def test_observation_noise_per_group_of_terms() -> None:
    """One event per group of observation terms, each with its own std; the terms named in neither stay clean."""
    text = NO_RESET_NOISE + event("n1", "observation_noise", "INTERVAL", 1, std="0.1", terms='["joint_pos"]')
    text += event("n2", "observation_noise", "INTERVAL", 1, std="0.01", terms='["cube_offset", "goal_offset"]')
    env, quiet = env_with(text, 64), env_with(NO_RESET_NOISE, 64)
    noisy, *_ = env.step(np.zeros((64, 6)))
    clean, *_ = quiet.step(np.zeros((64, 6)))
    noise = noisy - clean  # joint_pos 0-5, joint_vel 6-11, servo_error 12-17, cube_offset 18-20, goal_offset 21-23
    assert 0.08 < noise[:, :6].std() < 0.12
    assert 0.008 < noise[:, 18:24].std() < 0.012
    np.testing.assert_allclose(noise[:, 6:18], 0.0, atol=1e-9)
    np.testing.assert_allclose(noise[:, 24:], 0.0, atol=1e-9)


def test_desynchronised_first_episodes_end_in_every_stretch_of_steps() -> None:
    env = make_vector_env(TASK, 16, seed=0, nthread=1, episode_length=40)
    env.desync_episodes = True
    env.reset(seed=0)
    ended = []
    for _ in range(4):  # four "iterations" of 10 steps
        count = 0
        for _ in range(10):
            *_, infos = env.step(np.zeros((16, 6)))
            count += int(infos.get("_episode", np.zeros(16, bool)).sum())
        ended.append(count)
    assert all(count > 0 for count in ended), ended  # in lockstep all 16 would end together at step 40
    assert sum(ended) == 16


def test_appearance_draws_reach_each_simulations_model_and_its_camera() -> None:
    """On the CPU each simulation's model holds its colour, camera and light draw, and its kinematics place the
    camera where the drawn pose puts it (cam_xpos = cam_pos for a camera of the world body)."""
    env = env_with(
        event("c", "randomize_geom_rgba", geoms='["cube"]', green="[0.0, 0.1]", brightness="[0.5, 1.0]")
        + event("p", "randomize_camera_pose", cameras='["side"]', position="[-0.05, 0.05]", rotation="[-0.1, 0.1]")
        + event("l", "randomize_light", lights='["key"]', direction="[-0.2, 0.2]", diffuse="[0.2, 0.5]")
    )
    simulation, defaults = env.simulation, env.task.defaults
    cube, side, key = (
        getattr(simulation.model, kind)(name).id
        for kind, name in [("geom", "cube"), ("camera", "side"), ("light", "key")]
    )
    rgba = simulation.physics.batch.expanded("geom_rgba")[:, cube]
    np.testing.assert_allclose(defaults["geom_rgba"][cube], simulation.model.mat_rgba[simulation.model.mat("cube").id])
    assert np.all(rgba[:, 1] <= 0.1 * defaults["geom_rgba"][cube, 1] + 1e-12) and np.all(rgba[:, 0] < 0.85)
    quat = simulation.physics.batch.expanded("cam_quat")[:, side]
    np.testing.assert_allclose(np.linalg.norm(quat, axis=1), 1.0, atol=1e-12)
    assert np.all(np.abs(simulation.physics.batch.expanded("cam_pos")[:, side] - defaults["cam_pos"][side]) <= 0.05)
    direction = simulation.physics.batch.expanded("light_dir")[:, key]
    np.testing.assert_allclose(
        np.linalg.norm(direction, axis=1), np.linalg.norm(defaults["light_dir"][key]), atol=1e-12
    )
    assert len(np.unique(simulation.params["light_diffuse"][:, key, 0])) == simulation.num_envs
    for index in range(simulation.num_envs):
        model, data = simulation.physics.model_and_data(index)
        np.testing.assert_allclose(data.cam_xpos[side], simulation.params["cam_pos"][index, side], atol=1e-12)
        np.testing.assert_allclose(model.geom_rgba[cube], rgba[index])
