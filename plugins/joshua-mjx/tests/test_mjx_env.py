"""The MJX backend on the CPU: the batched env matches the MuJoCo backend, resets per environment, shards over
devices, and the `mjx` engine tracks the CPU engine."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from collections.abc import Callable
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from joshua_core.errors import ConfigError, ModelError
from joshua_mjx.batch import where_env
from joshua_mjx.engine import MjxEngine
from joshua_mjx.env import make_mjx_env
from joshua_mjx.physics import mjx
from joshua_mujoco import MuJoCoEngine
from joshua_mujoco.vector import make_vector_env, task_config_from_options

NO_RESET_NOISE = {"reset_qpos_uniform": {"weight": 0}, "reset_qvel_normal": {"weight": 0}}


ANT_EPISODE = 50  # long enough to stand through 30 steps of contact, short enough to step to its end


@pytest.fixture(scope="module")
def ant_env():  # type: ignore[no-untyped-def]
    """4 Ants without reset noise, shared by the tests of one compiled step (an MJX step compiles for a minute)."""
    config = task_config_from_options({"terms": NO_RESET_NOISE, "episode_length": ANT_EPISODE})
    return make_mjx_env("ant_locomotion", 4, model_path="ant/ant.xml", task_config=config)


def test_mjx_env_matches_the_mujoco_backend_and_fails_non_finite_actions(ant_env) -> None:  # type: ignore[no-untyped-def]
    cpu = make_vector_env(
        "ant_locomotion", 4, model_path="ant/ant.xml", terms=NO_RESET_NOISE, episode_length=ANT_EPISODE, nthread=1
    )
    cpu_observation, _ = cpu.reset(seed=0)
    state = ant_env.reset(jax.random.PRNGKey(0))
    np.testing.assert_allclose(np.asarray(state.observation), cpu_observation, atol=1e-5)
    # random actions while the Ant drops to the floor: float32 MJX against float64 MuJoCo agree closely
    for action in np.random.default_rng(0).uniform(-1, 1, (3, 4, 8)):
        cpu_observation, cpu_reward, _, _, _ = cpu.step(action)
        state = ant_env.step(state, jnp.asarray(action))
        np.testing.assert_allclose(np.asarray(state.observation)[:, :27], cpu_observation[:, :27], atol=1e-3)
        np.testing.assert_allclose(np.asarray(state.reward), cpu_reward, atol=1e-4)
    # a non-finite action is never clipped into a control: its environment fails the step, as a blow-up does, and
    # restarts; the others step on as the CPU backend's do
    action = np.random.default_rng(1).uniform(-1, 1, (4, 8))
    cpu_observation, cpu_reward, _, _, _ = cpu.step(action)
    action[1, 2], action[2, 5] = np.inf, np.nan
    state = ant_env.step(state, jnp.asarray(action))
    assert np.asarray(state.episode.failed).tolist() == [False, True, True, False]
    assert np.asarray(state.episode.done).tolist() == [False, True, True, False]
    assert np.asarray(state.reward)[1:3].tolist() == [0.0, 0.0] and np.asarray(state.episode_step)[1:3].tolist() == [
        0,
        0,
    ]
    assert np.isfinite(np.asarray(state.observation)).all()
    np.testing.assert_allclose(np.asarray(state.observation)[[0, 3], :27], cpu_observation[[0, 3], :27], atol=1e-3)
    np.testing.assert_allclose(np.asarray(state.reward)[[0, 3]], cpu_reward[[0, 3]], atol=1e-4)
    cpu.close()


@pytest.mark.slow
def test_mjx_contacts_hold_the_ant_up_like_mujoco(ant_env) -> None:  # type: ignore[no-untyped-def]
    """Standing on its legs through 30 steps of contact; random actions on the floor would diverge chaotically."""
    env = ant_env
    cpu = make_vector_env(
        "ant_locomotion", 4, model_path="ant/ant.xml", terms=NO_RESET_NOISE, episode_length=ANT_EPISODE, nthread=1
    )
    cpu.reset(seed=0)
    state = env.reset(jax.random.PRNGKey(0))
    posture = np.tile([0.0, 0.5, 0.0, -0.5, 0.0, -0.5, 0.0, 0.5], (4, 1))
    for _ in range(30):
        cpu_observation, cpu_reward, _, _, _ = cpu.step(posture)
        state = env.step(state, jnp.asarray(posture))
    torso_height = np.asarray(state.observation)[:, 0]
    assert 0.3 < torso_height.min()  # standing, not fallen through the floor
    # the contact forces the terms read are rne_postconstraint's, though the step keeps no other of its outputs
    # jitted: one program, where the vmap run eagerly compiles each of its operations apart (5 s more on 2 cores)
    full = jax.jit(jax.vmap(mjx.rne_postconstraint, (None, 0)))(env.mjx_model, state.data)._impl.cfrc_ext
    assert np.abs(np.asarray(full)).max() > 1.0  # the feet press on the floor
    np.testing.assert_allclose(np.asarray(state.data._impl.cfrc_ext), np.asarray(full), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(torso_height, cpu_observation[:, 0], atol=1e-4)
    np.testing.assert_allclose(np.asarray(state.reward), cpu_reward, atol=5e-3)
    cpu.close()


@pytest.mark.slow
def test_autoreset_ends_episodes_at_the_length_and_reports_them(ant_env) -> None:  # type: ignore[no-untyped-def]
    state = ant_env.reset(jax.random.PRNGKey(1))
    action = jnp.full((4, 8), 0.5, jnp.float32)  # not weakly typed: the actions the step was compiled for
    returns = np.zeros(4)
    for step in range(1, ANT_EPISODE + 1):
        state = ant_env.step(state, action)
        returns += np.asarray(state.reward)
        if step < ANT_EPISODE:
            assert not np.asarray(state.episode.done).any() and (np.asarray(state.episode_step) == step).all()
    assert np.asarray(state.truncated).all() and np.asarray(state.episode.done).all()
    np.testing.assert_allclose(np.asarray(state.episode.return_), returns, rtol=1e-5)
    assert (np.asarray(state.episode.length) == ANT_EPISODE).all() and (np.asarray(state.episode_step) == 0).all()
    assert not np.allclose(np.asarray(state.final_observation), np.asarray(state.observation))
    np.testing.assert_allclose(np.asarray(state.data.qpos), np.tile(ant_env.task.initial_qpos, (4, 1)), atol=1e-6)


# Two differently compiled XLA programs (one env against a variant patched before tracing) may fuse and order the
# same float32 arithmetic differently, so they agree to rounding, not bit for bit (1.2e-7 seen on one machine).
# This is far above rounding and far below what leaving out a step input gives: without qacc_warmstart the
# solver's fields differ by up to 5e-3 within 6 env steps.
SAME_PHYSICS = {"rtol": 1e-4, "atol": 1e-5}


def assert_same_physics(ours: object, theirs: object, label: str) -> None:
    """Every leaf of two pytrees alike: integers and booleans equal, floats within SAME_PHYSICS."""
    for index, (a, b) in enumerate(zip(jax.tree.leaves(ours), jax.tree.leaves(theirs), strict=True)):
        a, b = np.asarray(a), np.asarray(b)
        assert a.shape == b.shape and a.dtype == b.dtype, (label, index)
        if np.issubdtype(a.dtype, np.inexact):
            np.testing.assert_allclose(a, b, **SAME_PHYSICS, err_msg=f"{label} leaf {index}")
        else:
            np.testing.assert_array_equal(a, b, err_msg=f"{label} leaf {index}")


def make_noisy_ant():  # type: ignore[no-untyped-def]
    """4 Ants with the task's reset noise and 3-step episodes; tests that patch one before tracing make their own."""
    config = task_config_from_options({"episode_length": 3})
    return make_mjx_env("ant_locomotion", 4, model_path="ant/ant.xml", task_config=config)


@pytest.fixture(scope="module")
def noisy_ant_env():  # type: ignore[no-untyped-def]
    return make_noisy_ant()


def test_reset_terms_draw_per_environment_and_repeat_with_the_key(noisy_ant_env) -> None:  # type: ignore[no-untyped-def]
    first, again, other = (noisy_ant_env.reset(jax.random.PRNGKey(seed)) for seed in (0, 0, 1))
    qpos = np.asarray(first.data.qpos)
    assert len({tuple(row) for row in qpos.round(6)}) == 4  # every environment its own start
    np.testing.assert_array_equal(qpos, np.asarray(again.data.qpos))
    assert not np.allclose(qpos, np.asarray(other.data.qpos))
    with pytest.raises(ConfigError, match="num_envs must be at least 1"):
        make_mjx_env("ant_locomotion", 0, model_path="ant/ant.xml")


@pytest.mark.slow
def test_episodes_restart_from_the_start_state_until_it_is_redrawn(noisy_ant_env) -> None:  # type: ignore[no-untyped-def]
    env, action = noisy_ant_env, jnp.full((4, 8), 0.2, jnp.float32)  # as the other tests: one compiled step
    first = state = env.reset(jax.random.PRNGKey(2))
    np.testing.assert_array_equal(np.asarray(first.start.qpos), np.asarray(first.data.qpos))
    for _ in range(3):
        state = env.step(state, action)
    assert np.asarray(state.truncated).all()  # autoreset to the reset's own draws
    np.testing.assert_allclose(np.asarray(state.data.qpos), np.asarray(first.data.qpos), atol=1e-6)
    np.testing.assert_allclose(np.asarray(state.observation), np.asarray(first.observation), atol=1e-5)

    redrawn = env.redraw_starts(state)
    np.testing.assert_array_equal(np.asarray(redrawn.data.qpos), np.asarray(state.data.qpos))  # episodes go on
    new_starts = np.asarray(redrawn.start.qpos)
    assert len({tuple(row) for row in new_starts.round(6)}) == 4
    assert not np.isclose(new_starts, np.asarray(first.start.qpos)).all(axis=1).any()  # every env drew anew
    np.testing.assert_array_equal(new_starts, np.asarray(env.redraw_starts(state).start.qpos))  # from the state's keys
    state = redrawn
    for _ in range(3):
        state = env.step(state, action)
    assert np.asarray(state.truncated).all()
    np.testing.assert_allclose(np.asarray(state.data.qpos), new_starts, atol=1e-6)


@pytest.mark.slow
def test_autoreset_takes_only_what_the_next_step_and_the_terms_read(noisy_ant_env) -> None:  # type: ignore[no-untyped-def]
    """Episodes restarted from part of their start's Data run as from all of it (to rounding: SAME_PHYSICS)."""
    whole = make_noisy_ant()
    whole._autoreset = lambda done, start, data: where_env(done, start, data)  # the whole Data, before tracing
    partial_state = whole_state = noisy_ant_env.reset(jax.random.PRNGKey(3))
    for action in np.random.default_rng(1).uniform(-1, 1, (6, 4, 8)):  # restarts on steps 3 and 6
        partial_state = noisy_ant_env.step(partial_state, jnp.asarray(action))
        whole_state = whole.step(whole_state, jnp.asarray(action))
        for name in ("observation", "reward", "final_observation"):
            assert_same_physics(getattr(partial_state, name), getattr(whole_state, name), name)
        for name in ("qpos", "qvel", "qacc_warmstart"):
            assert_same_physics(getattr(partial_state.data, name), getattr(whole_state.data, name), name)
    assert np.asarray(partial_state.truncated).all()  # just restarted: what the step recomputes was left as it was
    assert not np.array_equal(np.asarray(partial_state.data.geom_xpos), np.asarray(whole_state.data.geom_xpos))


@pytest.mark.slow
def test_physics_steps_pass_on_only_the_integration_state(noisy_ant_env) -> None:  # type: ignore[no-untyped-def]
    """An env step's physics steps hand only MuJoCo's integration state on; the Data it ends with is, field for
    field, what frame_skip whole `mjx.step` calls give, to rounding (restarts on steps 3 and 6 included)."""
    whole = make_noisy_ant()
    assert whole.task.frame_skip > 1
    whole._advance = lambda fields, data: jax.lax.fori_loop(  # before tracing
        0, whole.task.frame_skip, lambda _, d: whole._physics(mjx.step, fields, d), data
    )
    state = whole_state = noisy_ant_env.reset(jax.random.PRNGKey(4))
    # XLA's default fusion emitters for both, not the suite's older ones (conftest.TEST_XLA_FLAGS): those contract
    # the two programs' float arithmetic differently, up to 1e-2 in velocity-level fields of magnitude 100 by the
    # first step, more than leaving out a step input gives
    options = {"xla_cpu_use_fusion_emitters": True}
    action = jnp.zeros((4, 8), jnp.float32)
    step, whole_step = (jax.jit(env._step).lower(state, action).compile(options) for env in (noisy_ant_env, whole))
    for action in np.random.default_rng(2).uniform(-1, 1, (6, 4, 8)):
        state = step(state, jnp.asarray(action, jnp.float32))
        whole_state = whole_step(whole_state, jnp.asarray(action, jnp.float32))
        assert_same_physics(state.data, whole_state.data, "data")
        assert_same_physics(state.observation, whole_state.observation, "observation")


@pytest.mark.slow
def test_environments_shard_over_two_devices_with_the_same_results_as_one(
    on_two_cpu_devices: Callable[[str], subprocess.CompletedProcess[str]],
) -> None:
    script = textwrap.dedent(
        """
        import re, jax, jax.numpy as jnp, numpy as np
        from joshua_core.errors import ConfigError
        from joshua_mjx.env import make_mjx_env
        from joshua_ppo.iteration import make_iteration
        from joshua_ppo.settings import NetworkSettings, OptimizationSettings, ReturnSettings, RolloutSettings
        from joshua_ppo.state import init_state
        from joshua_ppo.train import train_ppo
        assert len(jax.devices()) == 2
        results = []  # ant_mjx.xml: the Ant the trainer uses; with its 4 foot contacts it compiles in half the time
        for devices in (jax.devices()[:1], jax.devices()):
            env = make_mjx_env("ant_locomotion", 4, model_path="ant/ant_mjx.xml", devices=devices)
            state = env.reset(jax.random.PRNGKey(3))
            for _ in range(3):  # laid out as reset's again: the step returns some fields (zero-size, constant)
                # replicated, and a step called with those would compile a second program
                state = jax.device_put(env.step(state, jnp.full((4, 8), 0.3)), env.sharding)
            results.append(np.asarray(state.data.qpos))
            print("devices", len(state.data.qpos.sharding.device_set))
        print("max difference", float(np.abs(results[0] - results[1]).max()))
        # minibatches of whole unrolls split over the devices (those of steps, the default: test_distributed.py's
        # two processes of two devices each)
        reports = []
        train_ppo(env, rollout=RolloutSettings(5, 1), returns=ReturnSettings(recompute_advantages=True),
                  optimization=OptimizationSettings(num_epochs=1, minibatch_size=10),
                  network=NetworkSettings(hidden_sizes=(16,)), total_timesteps=40,
                  on_progress=lambda report, state: reports.append(report))
        print("losses finite", all(np.isfinite(r.metrics["loss"]) for r in reports), len(reports))
        # zero-size arrays (the ant has no tendons, mocap bodies...) stay out of the per-device computation:
        # jaxlib 0.11's GPU compiler crashes on them there
        settings = dict(rollout=RolloutSettings(5, 1), optimization=OptimizationSettings(1, 10),
                        returns=ReturnSettings(), network=NetworkSettings(hidden_sizes=(16,)))
        state = init_state(env, seed=0, network=settings["network"], optimization=settings["optimization"])
        lowered = make_iteration(env, **settings).lower(state).as_text()
        region = re.search(r"manual_axes=\\{[^}]*\\}\\s*\\((.*?)\\)\\s*\\{", lowered, re.S).group(1)
        print("per-device inputs", len(re.findall(r"%arg\\d+: ", region)),
              "empty", len(re.findall(r"%arg\\d+: tensor<(?:\\d+x)*0x", region)))
        try:
            make_mjx_env("ant_locomotion", 3, model_path="ant/ant_mjx.xml")
        except ConfigError as error:
            print("error:", error)
        """
    )
    done = on_two_cpu_devices(script)
    lines = done.stdout.splitlines()
    assert "devices 1" in lines and "devices 2" in lines, done.stdout
    difference = float(next(line for line in lines if line.startswith("max difference")).split()[-1])
    assert difference < 1e-5, done.stdout
    assert "losses finite True 2" in lines, done.stdout
    inputs = next(line for line in lines if line.startswith("per-device inputs")).split()
    assert int(inputs[2]) > 50 and inputs[3:] == ["empty", "0"], done.stdout
    assert any("num_envs 3 must be a multiple of the 2 devices" in line for line in lines), done.stdout


@pytest.mark.slow
def test_the_mjx_engine_tracks_the_mujoco_engine() -> None:
    engines = MjxEngine("so_arm100/scene_mjx.xml"), MuJoCoEngine("so_arm100/scene_mjx.xml")
    for engine in engines:
        engine.reset("home")
        engine.set_ctrl([0.0, -0.5, 0.3, 0.0, 0.2, 0.0])
        for _ in range(4):  # state with contacts carries over between calls, as the HEADLESS mode steps
            engine.step(50)
    mjx_engine, cpu_engine = engines
    assert mjx_engine.time == pytest.approx(0.4, abs=1e-5)  # MJX keeps time in float32
    np.testing.assert_allclose(mjx_engine.get_qpos(), cpu_engine.get_qpos(), atol=1e-5)
    assert mjx_engine.render().std() > 5  # rendering works as on the mujoco backend


def test_plugin_entry_points_import_nothing_heavy() -> None:
    script = (
        "import sys, joshua_mjx.plugin, joshua_ppo.plugin, joshua_ppo; "
        "print(sorted(m for m in ('jax', 'flax', 'optax', 'mujoco') if m in sys.modules))"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60, check=True)
    assert done.stdout.strip() == "[]"
    listing = subprocess.run(
        [sys.executable, "-m", "joshua_core.cli", "plugins"], capture_output=True, text=True, timeout=60
    )
    assert "backend  mjx" in listing.stdout and "trainer  ppo" in listing.stdout, listing.stdout


def test_importing_the_backend_prints_nothing() -> None:
    """mujoco-mjx's "Failed to import warp" notice (Warp is optional and not installed) stays out of stdout."""
    done = subprocess.run(
        [sys.executable, "-c", "import joshua_mjx.env, mujoco.mjx; print('imported')"],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    assert done.stdout == "imported\n", done.stdout


def test_a_model_mjx_cannot_run_is_a_clear_error(tmp_path: Path) -> None:
    model = tmp_path / "cylinder_on_box.xml"
    model.write_text(
        '<mujoco><worldbody><geom type="box" size=".1 .1 .1"/>'
        '<body pos="0 0 1"><freejoint/><geom type="cylinder" size=".1 .1"/></body></worldbody></mujoco>'
    )
    with pytest.raises(
        ModelError, match=r"cylinder_on_box.xml: the model uses something MJX does not support .*CYLINDER"
    ):
        MjxEngine(model)
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "joshua_core.cli",
            "--set",
            "simulation.backend=mjx",
            "--set",
            f"simulation.model_path={model}",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2 and "MJX does not support" in done.stderr and "Traceback" not in done.stderr, (
        done.stderr
    )
