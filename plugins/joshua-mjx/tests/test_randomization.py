"""Domain randomization on both backends: the same sampled parameters give the same trajectories on the CPU
(mujoco.batch, per-simulation model fields + mj_setConst) and on MJX (a batched mjx.Model, on jax's CPU), with
MJX-JAX's and MuJoCo Warp's physics alike, and MJX recomputes the inverse weights that mj_setConst derives from
masses and armature. Tests of what does not depend on the physics (observation noise, the curriculum) step
MuJoCo Warp, whose steps compile in seconds where MJX-JAX's take tens of seconds on 2 cores."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from google.protobuf import text_format

from joshua_core.config_pb2 import TaskConfig
from joshua_mjx import EnvState, MjxEnv, Physics, make_mjx_env
from joshua_mujoco import make_vector_env

TASK, MODEL, ENVS, STEPS = "so_arm100_pick_place", "so_arm100/pick_place_mjx.xml", 3, 10
# Same model file on both; no reset noise, so that both start from the keyframe.
EVENTS = """
terms { name: "reset_joints_uniform" weight: 0 }
terms { name: "reset_free_joint_xy" weight: 0 }
events { name: "friction" term: "randomize_geom_friction" mode: RESET
         params { key: "geoms" value: "[\\"cube\\", \\"fixed_pad\\", \\"moving_pad\\"]" }
         params { key: "range" value: "[0.8, 1.2]" } }
events { name: "mass" term: "randomize_body_mass" mode: RESET
         params { key: "bodies" value: "[\\"cube\\", \\"fixed_jaw\\", \\"upper_arm\\"]" }
         params { key: "range" value: "[0.5, 2.0]" } params { key: "distribution" value: "log_uniform" } }
events { name: "gains" term: "randomize_actuator_gains" mode: RESET
         params { key: "kp_range" value: "[0.7, 1.3]" } params { key: "kv_range" value: "[0.7, 1.3]" } }
events { name: "damping" term: "randomize_joint_damping" mode: RESET params { key: "range" value: "[0.5, 1.5]" } }
events { name: "armature" term: "randomize_joint_armature" mode: RESET params { key: "range" value: "[0.5, 2.0]" } }
"""
# rad, over 10 steps (0.2 s): float32 MJX against float64 MuJoCo. Measured: 2.1e-3 to 4.5e-3 with the same
# drawn parameters (3.7e-3 with delta actions at full speed), 3.3e-3 between the backends without
# randomization; the draws move the arm by more than 5x the tolerance. Later
# the backends part more (1.8e-2 by step 20 even without randomization: contacts, solver), so the check
# stops at 10 steps.
PARITY_TOLERANCE = 1e-2
# rad, MJX-JAX against MuJoCo Warp with the same drawn parameters, both float32 but different kernels: over these
# 10 contact-rich steps rounding differences grow as between float32 and float64 above (2e-3 to 5e-3), and how far
# depends on how XLA happens to fuse the step (a change that leaves every value of a finite action as it was moved one
# joint 2.5e-3); a model that ignored the parameters would be off by more than 5 x PARITY_TOLERANCE (checked below)
JAX_WARP_TOLERANCE = 5e-3


def _config() -> TaskConfig:
    return text_format.Parse(EVENTS, TaskConfig())


def _actions(envs: int = ENVS) -> np.ndarray:
    t = np.arange(STEPS)[:, None, None] * 0.02
    phase = np.arange(6)[None, None, :] + np.arange(envs)[None, :, None]
    return np.sin(2.0 * np.pi * 0.8 * t + phase)  # delta actions: the targets move up to 0.05 rad per step


def _cpu_run() -> tuple[dict[str, np.ndarray], np.ndarray, object]:
    env = make_vector_env(TASK, ENVS, seed=5, model_path=MODEL, task_config=_config(), nthread=1)
    simulation = env.simulation
    params = {name: value.copy() for name, value in simulation.params.items()}
    qpos = []
    for action in _actions():
        env.step(action)
        qpos.append(simulation.qpos.copy())
    return params, np.array(qpos), simulation


def _split(env: MjxEnv, state: EnvState) -> EnvState:
    """The state split by environment as reset returns it. The step's outputs come back replicated, and a
    step called with them compiles again (about 45 s on the CPU for pick-and-place): one compile per env."""
    return jax.device_put(state, env.sharding)


def _mjx_run(env: MjxEnv, params: dict[str, np.ndarray]) -> np.ndarray:
    """MJX's trajectory with the given drawn parameters (and MJX's inverse weights of them)."""
    state = env.reset(jax.random.PRNGKey(0))
    drawn = env.randomization.with_derived({name: jnp.asarray(value) for name, value in params.items()})
    state = _split(env, state._replace(params=drawn, start_params=drawn))
    qpos = []
    for action in _actions():
        state = _split(env, env.step(state, jnp.asarray(action, jnp.float32)))
        qpos.append(np.asarray(state.data.qpos))
    return np.array(qpos)


@pytest.mark.slow
def test_same_parameters_give_the_same_trajectories_on_both_backends() -> None:
    pytest.importorskip("mujoco_warp", reason="MJX-Warp needs joshua-mjx[warp] (warp-lang, mujoco-warp)")
    params, cpu, _ = _cpu_run()
    env = make_mjx_env(TASK, ENVS, model_path=MODEL, task_config=_config())
    arm = slice(0, 6)
    randomized = _mjx_run(env, params)
    error = np.abs(randomized[..., arm] - cpu[..., arm]).max()
    print(f"max joint difference CPU vs MJX, same parameters: {error:.2e} rad")
    assert error < PARITY_TOLERANCE
    # MuJoCo Warp's model takes the same per-environment values (with their derived inverse weights) as MJX-JAX's
    warp = _mjx_run(make_mjx_env(TASK, ENVS, model_path=MODEL, task_config=_config(), physics=Physics("warp")), params)
    np.testing.assert_allclose(warp, randomized, atol=JAX_WARP_TOLERANCE)
    # MJX with the model's own values: the parameters do move the arm, far more than the tolerance
    defaults = {name: np.broadcast_to(env.task.defaults[name], value.shape) for name, value in params.items()}
    nominal = _mjx_run(env, defaults)
    assert np.abs(nominal[..., arm] - cpu[..., arm]).max() > 5 * PARITY_TOLERANCE


@pytest.mark.slow  # compiles MJX forward passes over randomized models: 30 s on 2 cores
def test_mjx_recomputes_the_inverse_weights_mj_setconst_derives() -> None:
    params, _, simulation = _cpu_run()
    env = make_mjx_env(TASK, ENVS, model_path=MODEL, task_config=_config())
    drawn = env.randomization.with_derived({name: jnp.asarray(value) for name, value in params.items()})
    for name in ("body_invweight0", "dof_invweight0"):
        expected = simulation.physics.batch.expanded(name)  # mj_setConst of each simulation, per simulation
        np.testing.assert_allclose(np.asarray(drawn[name]), expected, rtol=2e-4, atol=1e-6)
        assert not np.allclose(expected, getattr(env.model, name)[None], rtol=1e-2)  # they did change


NOISE = """
events { name: "noise" term: "observation_noise" mode: INTERVAL interval_steps: 1 params { key: "std" value: "0.5" } }
"""


@pytest.mark.slow
def test_the_value_observation_is_the_observation_without_its_noise() -> None:
    # the noise is a task- and physics-independent event: reach on MuJoCo Warp, whose steps compile in seconds
    pytest.importorskip("mujoco_warp", reason="MJX-Warp needs joshua-mjx[warp] (warp-lang, mujoco-warp)")
    noise = text_format.Parse(NOISE, TaskConfig())
    plain = make_mjx_env("so_arm100_reach", 2, physics=Physics("warp"))
    noisy = make_mjx_env("so_arm100_reach", 2, task_config=noise, physics=Physics("warp"))
    states = [env.reset(jax.random.PRNGKey(3)) for env in (plain, noisy)]
    assert states[0].value_observation is None and states[0].final_value_observation is None  # nothing to hide
    for action in _actions(2):
        states = [
            _split(env, env.step(state, jnp.asarray(action, jnp.float32)))
            for env, state in zip((plain, noisy), states, strict=True)
        ]
        clean, noise = np.asarray(states[1].value_observation), np.asarray(states[1].params["obs_noise"])
        # the noise changes what the policy sees, not the physics: the clean view is the noise-free task's
        np.testing.assert_allclose(clean, np.asarray(states[0].observation), rtol=1e-5, atol=1e-5)
        np.testing.assert_allclose(np.asarray(states[1].observation) - clean, noise, rtol=1e-5, atol=1e-5)
        np.testing.assert_allclose(np.asarray(states[1].final_value_observation), clean, rtol=1e-5, atol=1e-5)
        assert 0.3 < noise.std() < 0.7


@pytest.mark.slow
def test_training_environments_ease_the_events_in_as_their_episodes_succeed() -> None:
    """The randomization curriculum inside the compiled step: strength 0 draws nothing, each successful episode
    (here every one: the metric is `alive`) raises the environment's strength, evaluation draws at full strength."""
    from joshua_core.config_pb2 import TrainingConfig
    from joshua_core.interfaces import EnvKind, EnvSpec
    from joshua_core.plugins import PluginHost
    from joshua_mjx.options_pb2 import MjxOptions
    from joshua_mjx.options_pb2 import mjx as mjx_options

    pytest.importorskip("mujoco_warp", reason="MJX-Warp needs joshua-mjx[warp] (warp-lang, mujoco-warp)")

    config = text_format.Parse(
        """episode_length: 2
        terms { name: "always" term: "alive" kind: METRIC }
        events { name: "noise" term: "observation_noise" mode: INTERVAL interval_steps: 1
                 params { key: "std" value: "0.1" } }
        events { name: "damping" term: "randomize_joint_damping" mode: RESET params { key: "range" value: "[2, 3]" } }
        randomization_curriculum { metric: "always" start: 0 step_up: 0.5 }""",
        TaskConfig(),
    )
    plugins = PluginHost.discover()
    mjx_backend = plugins.backend("mjx")
    training = TrainingConfig()
    training.Extensions[mjx_options].impl = MjxOptions.WARP  # the curriculum does not depend on the physics

    def envs(curriculum: bool) -> MjxEnv:
        spec = EnvSpec("so_arm100_reach", 2, task_config=config, curriculum=curriculum, training=training)
        return mjx_backend.create_envs(spec, EnvKind.JAX, plugins)

    env = envs(curriculum=True)
    default_damping = env.task.defaults["dof_damping"]
    state = env.reset(jax.random.key(0))
    # strength 0: the model's own damping, to float32 rounding (MJX's params are float32)
    np.testing.assert_allclose(
        state.params["dof_damping"], np.broadcast_to(default_damping, (2, env.model.nv)), rtol=1e-6
    )
    action = jnp.zeros((2, env.action_size))
    noises, strengths = [], []
    for _ in range(6):
        state = env.step(state, action)
        noises.append(float(jnp.abs(state.observation - state.value_observation).max()))
        strengths.append(np.asarray(state.strength).tolist())
    # an episode ends every 2 steps, each one a success (+0.5, capped at 1)
    assert strengths == [[0.0, 0.0], [0.5, 0.5], [0.5, 0.5], [1.0, 1.0], [1.0, 1.0], [1.0, 1.0]]
    # noise is drawn on each step after an episode's first observation: at strength 0, then 0.5 (std 0.05), then 1
    assert noises[0] == 0.0 and noises[2] > 0.01 and noises[4] > 0.01, noises
    assert np.asarray(state.episode.metrics["randomization_strength"]).tolist() == [1.0, 1.0]
    state = env.redraw_starts(state)  # the next episodes' damping at strength 1: x U(2, 3)
    ratio = np.asarray(state.start_params["dof_damping"])[:, default_damping > 0] / default_damping[default_damping > 0]
    assert 2.0 <= ratio.min() and ratio.max() <= 3.0

    evaluation = envs(curriculum=False).reset(jax.random.key(0))
    assert np.asarray(evaluation.strength).tolist() == [1.0, 1.0]
    ratio = np.asarray(evaluation.params["dof_damping"])[:, default_damping > 0] / default_damping[default_damping > 0]
    assert 2.0 <= ratio.min() and ratio.max() <= 3.0
