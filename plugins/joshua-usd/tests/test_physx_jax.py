"""The `usd` backend's JAX environments on PhysX (`joshua_usd.physx_jax`, CPU PhysX here): the same task on the
same scene as the NUMPY PhysX environments, stepped from a compiled program through Warp's JAX FFI; rollouts are
functions of their start state; contact wrenches balance the robot's weight; what PhysX cannot step is refused
in one line; PPO trains on it from the command line."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.interfaces import EnvKind, EnvSpec
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_mujoco.vector import task_config_from_options
from joshua_usd.options_pb2 import UsdOptions, usd

pytest.importorskip("ovphysx")
jax = pytest.importorskip("jax")
jnp = jax.numpy

NO_RESET_NOISE = {"reset_joints_uniform": {"weight": 0}, "reset_qvel_normal": {"weight": 0}}
NUM_ENVS, STEPS = 3, 10
# Both kinds step the same float32 PhysX scene; the JAX one converts its state to MuJoCo's layout in float32, the
# NUMPY one in float64, so joint angles part by rounding that contacts amplify a little over 10 steps
STATE_TOLERANCE = 1e-3  # rad, m
FEET = ("front_left_shin", "front_right_shin", "back_shin", "right_back_shin")


def spec(num_envs: int = NUM_ENVS, terms: dict | None = None) -> EnvSpec:
    training = TrainingConfig()
    training.Extensions[usd].physics = UsdOptions.PHYSX
    return EnvSpec(
        "isaac_ant_locomotion",
        num_envs,
        model_path=resolve_data_path("isaac/ant.usd"),
        task_config=task_config_from_options({"terms": terms or NO_RESET_NOISE}),
        training=training,
    )


@pytest.fixture(scope="module")
def plugins() -> PluginHost:
    return PluginHost.discover()


@pytest.fixture(scope="module")
def ant(plugins: PluginHost):  # type: ignore[no-untyped-def]
    from joshua_usd.physx_jax import PhysxJaxPhysics

    env = plugins.backend("usd").create_envs(spec(), EnvKind.JAX, plugins)
    assert isinstance(env.external, PhysxJaxPhysics)
    return env


def actions() -> np.ndarray:
    """Environment 0 pushes every joint one way, environment 1 the other, environment 2 rests."""
    action = np.zeros((NUM_ENVS, 8), np.float32)
    action[0], action[1] = 1.0, -1.0
    return action


def test_jax_physx_steps_as_numpy_physx_does(ant, plugins: PluginHost) -> None:  # type: ignore[no-untyped-def]
    numpy_env = plugins.backend("usd").create_envs(spec(), EnvKind.NUMPY, plugins)
    try:
        state = ant.reset(jax.random.PRNGKey(0))
        numpy_env.reset(seed=0)
        start = np.asarray(state.data.qpos)
        np.testing.assert_allclose(start, numpy_env.qpos, atol=STATE_TOLERANCE)
        for _ in range(STEPS):
            state = ant.step(state, jnp.asarray(actions()))
            observation, reward, *_ = numpy_env.step(actions())
        qpos = np.asarray(state.data.qpos)
        np.testing.assert_allclose(qpos, numpy_env.qpos, atol=STATE_TOLERANCE)
        np.testing.assert_allclose(np.asarray(state.reward), reward, atol=1e-2)
        # hips (columns 0, 2, 4, 6 of the joints) driven at full torque reach their limits (0.52 rad); the resting
        # clone's barely move: the clones are independent
        moved = qpos[:, 7:] - start[:, 7:]
        assert (moved[0, ::2] > 0.1).all() and (moved[1, ::2] < -0.1).all(), moved
        assert np.abs(moved[2, ::2]).max() < 0.05, moved
        assert np.isfinite(np.asarray(state.observation)).all()
    finally:
        numpy_env.close()


def test_a_rollout_is_a_function_of_its_start_state(ant) -> None:  # type: ignore[no-untyped-def]
    """PhysX is written the start state where it holds another: the same compiled rollout run twice from one
    state ends alike, and an autoreset's start state reaches PhysX."""
    rollout = jax.jit(lambda s, a: jax.lax.scan(lambda s, a: (ant.step(s, a), None), s, a)[0])
    sequence = jnp.broadcast_to(jnp.asarray(actions()), (STEPS, NUM_ENVS, 8))
    state = ant.reset(jax.random.PRNGKey(1))
    first = np.asarray(rollout(state, sequence).data.qpos)
    second = np.asarray(rollout(state, sequence).data.qpos)
    np.testing.assert_allclose(second, first, atol=STATE_TOLERANCE)
    assert np.abs(first - np.asarray(state.data.qpos)).max() > 0.1  # the rollout moved the robots


def test_contact_wrenches_balance_the_weight_about_the_centre_of_mass(ant) -> None:  # type: ignore[no-untyped-def]
    state = ant.reset(jax.random.PRNGKey(0))
    rest = jnp.zeros((NUM_ENVS, 8))
    for _ in range(50):
        state = ant.step(state, rest)
    model = ant.model
    wrench = np.asarray(state.data._impl.cfrc_ext)
    feet = [model.body(name).id for name in FEET]
    weight = float(model.body_subtreemass[1] * -model.opt.gravity[2])
    for env in range(NUM_ENVS):  # the clones stand in lanes 20 m apart: no lane offset may enter the torques
        torque, force = wrench[env, feet, :3], wrench[env, feet, 3:]
        scale = np.abs(torque).sum()
        assert scale > 1.0
        np.testing.assert_allclose(torque.sum(axis=0), 0.0, atol=0.02 * scale)
        np.testing.assert_allclose(force.sum(axis=0), [0.0, 0.0, weight], atol=0.02 * weight)


@pytest.mark.slow  # a PhysX scene and a compiled step of its own: 13 s
def test_randomized_masses_reach_physx_per_environment(plugins: PluginHost) -> None:
    """randomize_body_mass's draws become each clone's PhysX link mass and inertia (scaled alike) when its episode
    starts; a clone whose episode goes on keeps its own."""
    from ovphysx.types import TensorType

    from joshua_core.config_pb2 import EventConfig, TaskConfig

    config = TaskConfig()
    config.CopyFrom(task_config_from_options({"terms": NO_RESET_NOISE}))
    event = config.events.add(name="torso_mass", term="randomize_body_mass", mode=EventConfig.RESET)
    event.params["bodies"] = '["torso"]'
    event.params["range"] = "[0.5, 2.0]"
    env_spec = spec()
    env = plugins.backend("usd").create_envs(
        EnvSpec(
            env_spec.task, NUM_ENVS, model_path=env_spec.model_path, task_config=config, training=env_spec.training
        ),
        EnvKind.JAX,
        plugins,
    )
    state = env.step(env.reset(jax.random.PRNGKey(3)), jnp.zeros((NUM_ENVS, 8)))
    torso = env.model.body("torso").id
    factor = np.asarray(state.params["body_mass"])[:, torso] / env.model.body_mass[torso]
    assert np.ptp(factor) > 0.05 and ((factor >= 0.5) & (factor <= 2.0)).all(), factor
    scene = env.external.scene
    column = list(scene.bodies).index(torso)
    mass, inertia = scene.bind(TensorType.ARTICULATION_BODY_MASS), scene.bind(TensorType.ARTICULATION_BODY_INERTIA)
    masses, inertias = np.zeros(mass.shape, np.float32), np.zeros(inertia.shape, np.float32)
    mass.read(masses)
    inertia.read(inertias)
    np.testing.assert_allclose(masses[:, column] / masses[0, column], factor / factor[0], rtol=1e-5)
    scale = (factor / factor[0]).reshape(-1, *(1,) * (inertias.ndim - 2))
    np.testing.assert_allclose(inertias[:, column], inertias[0, column] * scale, rtol=1e-5, atol=1e-9)


def test_what_physx_cannot_step_is_refused_in_one_line(plugins: PluginHost) -> None:
    from joshua_core.tasks import build_task, load_task_spec
    from joshua_mjx.env import _check_external
    from joshua_mjx.impl import Physics
    from joshua_usd.physx_jax import PhysxJaxPhysics

    task = build_task(load_task_spec("isaac_ant_locomotion", plugins), _ant_model(plugins), plugins, None)
    physics = PhysxJaxPhysics.__new__(PhysxJaxPhysics)  # what it gives and takes are class attributes
    device = jax.devices()[0]
    with pytest.raises(ConfigError, match=r"one device, not 2; set CUDA_VISIBLE_DEVICES") as error:
        _check_external(physics, task, Physics(), [device, device])
    assert "\n" not in str(error.value)
    task.fields = task.fields | {"sensordata"}
    with pytest.raises(ConfigError, match=r"its terms read sensordata, which its physics does not give"):
        _check_external(physics, task, Physics(), [device])
    task.fields = task.fields - {"sensordata"}
    task.param_fields = ("geom_friction",)
    taken = "actuator_biasprm, actuator_gainprm, body_inertia, body_mass"
    with pytest.raises(ConfigError, match=rf"randomize geom_friction, .* \(it takes {taken}\)"):
        _check_external(physics, task, Physics(), [device])


def _ant_model(plugins: PluginHost):  # type: ignore[no-untyped-def]
    from joshua_mujoco import compile_model

    return compile_model(resolve_data_path("isaac/ant.usd"), plugins=plugins)


@pytest.mark.slow
def test_ppo_trains_on_physx_from_the_command_line(tmp_path: Path) -> None:
    import subprocess

    command = [
        sys.executable, "-m", "joshua_core.cli", "--preset", "isaac_ant_mjx",
        "--set", "training.usd.physics=PHYSX", "--set", "training.num_envs=4", "--set", "training.num_steps=4",
        "--set", "training.minibatch_size=8", "--set", "training.total_timesteps=16",
        "--set", "training.ppo.video_interval=-1",
        "--set", f"training.checkpoint_dir={tmp_path}",
    ]  # fmt: skip
    done = subprocess.run(command, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    params = list(tmp_path.rglob("params.msgpack"))
    assert params, sorted(p.name for p in tmp_path.rglob("*"))
    assert (params[0].parent / "metrics.json").is_file()
