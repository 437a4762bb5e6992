"""The `usd` backend on PhysX (ovphysx, CPU here): the Isaac Ant stage and an exported MJCF robot step as
cloned, independent NUMPY environments under the same task terms as on MuJoCo; configs choose it with
`training.usd { physics: PHYSX }`; a term reading what PhysX does not give fails in one line."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from pxr import Usd

from joshua_core.config import apply_override, load_preset
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.interfaces import EnvKind, EnvSpec
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_mujoco.vector import load_task_model, task_config_from_options
from joshua_usd import physx_schema
from joshua_usd.backend import uses_physx
from joshua_usd.options_pb2 import UsdOptions, usd
from joshua_usd.physx import GPU_CAPACITIES, _articulation_root, _prepared_stage

pytest.importorskip("ovphysx")

NO_RESET_NOISE = {"reset_joints_uniform": {"weight": 0}, "reset_qvel_normal": {"weight": 0}}
NUM_ENVS, STEPS = 3, 10
# float32 PhysX link poses against float64 MuJoCo forward kinematics of the same joint positions
KINEMATICS_TOLERANCE = 1e-4


def physx_training(**fields: object) -> TrainingConfig:
    training = TrainingConfig(**fields)
    training.Extensions[usd].physics = UsdOptions.PHYSX
    return training


def ant_spec(num_envs: int = NUM_ENVS, terms: dict | None = None) -> EnvSpec:
    config = task_config_from_options({"terms": terms or NO_RESET_NOISE})
    return EnvSpec(
        "isaac_ant_locomotion",
        num_envs,
        model_path=resolve_data_path("isaac/ant.usd"),
        task_config=config,
        training=physx_training(),
    )


@pytest.fixture(scope="module")
def plugins() -> PluginHost:
    return PluginHost.discover()


@pytest.fixture(scope="module")
def ant(plugins: PluginHost):  # type: ignore[no-untyped-def]
    env = plugins.backend("usd").create_envs(ant_spec(), EnvKind.NUMPY, plugins)
    yield env
    env.close()


def test_ant_steps_on_physx_and_its_joints_follow_the_actions(ant) -> None:  # type: ignore[no-untyped-def]
    from joshua_usd.physx import PhysxBatchPhysics

    assert isinstance(ant.simulation.physics, PhysxBatchPhysics)
    observation, _ = ant.reset(seed=0)
    assert observation.shape == (NUM_ENVS, 60)
    start = ant.qpos[:, 7:].copy()
    actions = np.zeros((NUM_ENVS, 8))
    actions[0] = 1.0  # env 0 pushes every joint one way, env 1 the other, env 2 rests
    actions[1] = -1.0
    for _ in range(STEPS):
        observation, reward, terminated, truncated, _ = ant.step(actions)
        assert np.isfinite(observation).all() and np.isfinite(reward).all()
    moved = ant.qpos[:, 7:] - start
    # hips (columns 0, 2, 4, 6 of the joints) driven at full torque move towards their limits (0.52 rad)
    assert (moved[0, ::2] > 0.1).all() and (moved[1, ::2] < -0.1).all(), moved
    # the clones are independent: a resting Ant's hips barely move while its neighbours' swing
    assert np.abs(moved[2, ::2]).max() < 0.05, moved


def test_physx_link_poses_are_mujocos_forward_kinematics(ant) -> None:  # type: ignore[no-untyped-def]
    physics = ant.simulation.physics
    model = physics.model
    q = model.qpos0.copy()
    q[2] = 1.5
    q[7:] = [0.3, 0.8, -0.2, -0.9, 0.1, -0.7, 0.4, 0.6]  # inside every joint's limits
    physics.field("qpos")[:] = q
    physics.field("qvel")[:] = 0.0
    physics.forward(np.arange(NUM_ENVS))
    data = mujoco.MjData(model)
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    for env in range(NUM_ENVS):
        np.testing.assert_allclose(physics.field("qpos")[env], q, atol=KINEMATICS_TOLERANCE)
        np.testing.assert_allclose(physics.field("xpos")[env, 1:], data.xpos[1:], atol=KINEMATICS_TOLERANCE)
    ant.reset(seed=0)


def test_a_term_reading_what_physx_lacks_fails_in_one_line(plugins: PluginHost) -> None:
    from joshua_usd.physx import PhysxBatchPhysics

    task, model = load_task_model("isaac_ant_locomotion", None, plugins, None)
    with pytest.raises(ConfigError, match=r"^backend usd, physics PHYSX: the task's terms read sensordata, ") as error:
        PhysxBatchPhysics(model, resolve_data_path("isaac/ant.usd"), 1, task.fields | {"sensordata"})
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("preset", ["isaac_ant_locomotion", "isaac_trileg"])
def test_the_isaac_presets_choose_physx(preset: str, plugins: PluginHost) -> None:
    options = plugins.options()
    config = load_preset(preset, options).message
    assert not uses_physx(config.training)  # MuJoCo stays the default
    apply_override(config, "training.usd.physics=PHYSX", options)
    assert uses_physx(config.training)


def test_an_mjcf_robot_reaches_physx_through_the_exporter(plugins: PluginHost) -> None:
    spec = EnvSpec(
        "ant_locomotion",
        2,
        task_config=task_config_from_options({"terms": {}}),
        training=physx_training(),
    )
    env = plugins.backend("usd").create_envs(spec, EnvKind.NUMPY, plugins)
    try:
        env.reset(seed=0)
        start = env.qpos.copy()
        for _ in range(5):
            observation, reward, *_ = env.step(np.ones((2, env.task.action_size)))
        assert np.isfinite(observation).all() and np.isfinite(reward).all()
        assert np.abs(env.qpos[:, 7:] - start[:, 7:]).max() > 0.05
    finally:
        env.close()


# An Ant at rest: its feet's contact wrenches about its centre of mass balance its weight, which acts there.
REST_STEPS = 100
EQUILIBRIUM_TOLERANCE = 0.02  # of the feet's summed torque magnitude (several N·m), or of the weight (N)


@pytest.mark.parametrize("physics", [UsdOptions.MUJOCO, UsdOptions.PHYSX])
def test_cfrc_ext_torques_are_about_the_robots_centre_of_mass(physics: int, plugins: PluginHost) -> None:
    training = TrainingConfig()
    training.Extensions[usd].physics = physics
    spec = EnvSpec(
        "isaac_ant_locomotion",
        2,  # the second clone stands in its own lane: its torques must not carry the lane's offset
        model_path=resolve_data_path("isaac/ant.usd"),
        task_config=task_config_from_options({"terms": NO_RESET_NOISE}),
        training=training,
    )
    env = plugins.backend("usd").create_envs(spec, EnvKind.NUMPY, plugins)
    try:
        env.reset(seed=0)
        for _ in range(REST_STEPS):
            env.step(np.zeros((2, 8)))
        model = env.simulation.physics.model
        wrench = env.simulation.physics.field("cfrc_ext")
        feet = [model.body(name).id for name in ("front_left_shin", "front_right_shin", "back_shin", "right_back_shin")]
        weight = float(model.body_subtreemass[1] * -model.opt.gravity[2])
        for env_index in range(2):
            torque, force = wrench[env_index, feet, :3], wrench[env_index, feet, 3:]
            scale = np.abs(torque).sum()
            assert scale > 1.0  # each foot carries a quarter of the weight about 0.75 m (x and y) from the centre
            np.testing.assert_allclose(torque.sum(axis=0), 0.0, atol=EQUILIBRIUM_TOLERANCE * scale)
            np.testing.assert_allclose(force.sum(axis=0), [0.0, 0.0, weight], atol=EQUILIBRIUM_TOLERANCE * weight)
            # the front-left foot (+x, +y of the centre) pushed up: torque +x, -y, as r x F gives
            assert torque[0, 0] > 0.5 and torque[0, 1] < -0.5, torque
    finally:
        env.close()


def test_the_gpu_scene_is_sized_for_its_clones_with_the_schemas_types(tmp_path: Path) -> None:
    source = resolve_data_path("isaac/ant.usd")
    root = _articulation_root(source)
    assert _prepared_stage(source, root, tmp_path, 8192, contacts=False, gpu=False) == source  # nothing to author
    stage = Usd.Stage.Open(str(_prepared_stage(source, root, tmp_path, 8192, contacts=False, gpu=True)))
    scene = stage.GetPrimAtPath("/PhysicsScene")
    authored = {
        name: scene.GetAttribute(physx_schema.attribute_name("PhysxSceneAPI", name)).Get() for name in GPU_CAPACITIES
    }
    assert authored["gpuTotalAggregatePairsCapacity"] == 8 * 8192  # 1025-2047 needed by 8192 Ants on a GPU
    assert authored["gpuFoundLostAggregatePairsCapacity"] >= 5845  # the most a GPU run asked for
    assert all(value >= default for value, (_, default) in zip(authored.values(), GPU_CAPACITIES.values(), strict=True))
    if physx_schema.registered():
        assert physx_schema.check_stage(stage) == []  # names and types as the PhysX schemas declare them
