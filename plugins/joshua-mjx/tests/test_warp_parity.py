"""MuJoCo Warp behind the same environments: a task stepped by MJX-Warp agrees with MJX-JAX and with MuJoCo on
the CPU (docs/training-mjx.md#physics-implementation).

Warp runs on the CPU here (its kernels compile for the CPU; the first run of a scene fills Warp's kernel cache).
Kept small for CI: 2 environments, STEPS environment steps each. Each environment step is frame_skip physics
steps of the task's MJX model from the same start (reset noise on: the JAX and Warp environments draw the same
starts from the same key; MuJoCo starts from the JAX environment's first start and applies the controls that
environment applied). Tolerances: MJX-JAX against MJX-Warp, both float32, within JAX_WARP_TOL; against
float64 MuJoCo within CPU_TOL (Ant, which lands meanwhile: CPU_TOL_OF), joint positions in radians and metres.
Pick-and-place, the costliest scene to compile, is compared with its model randomized, in test_randomization.py.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from collections.abc import Callable

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from joshua_mjx import MjxEnv, Physics, make_mjx_env

pytest.importorskip("mujoco_warp", reason="MJX-Warp needs joshua-mjx[warp] (warp-lang, mujoco-warp)")

ENVS = 2
STEPS = 8
JAX_WARP_TOL = 2e-3
CPU_TOL = 2e-3
# Ant lands on its legs within the steps: float32 against float64 contact solutions part by 1.2e-2 by then (measured)
CPU_TOL_OF = {"ant_locomotion": 2e-2}


def _actions(env: MjxEnv) -> np.ndarray:
    """STEPS smooth actions, different per environment and joint, the same for every implementation."""
    t = np.arange(STEPS)[:, None, None]
    phase = np.arange(ENVS)[None, :, None] + np.arange(env.action_size)[None, None, :]
    return (0.5 * np.sin(0.4 * t + phase)).astype(np.float32)


def _unit_quaternions(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """`qpos` with each free joint's quaternion normalised: a reset term's noise leaves it off unit length, which
    MJX-JAX's forward normalises in qpos and MuJoCo Warp's only where it uses it (the same pose either way)."""
    qpos = qpos.copy()
    for joint in np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE):
        quat = slice(model.jnt_qposadr[joint] + 3, model.jnt_qposadr[joint] + 7)
        qpos[..., quat] /= np.linalg.norm(qpos[..., quat], axis=-1, keepdims=True)
    return qpos


def _rollout(env: MjxEnv) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(qpos (STEPS, ENVS, nq), ctrl (STEPS, ENVS, nu), the first start's qpos and qvel) of `env` from key 0."""
    state = env.reset(jax.random.PRNGKey(0))
    start = np.asarray(state.data.qpos[0]), np.asarray(state.data.qvel[0])
    qpos, ctrl = [], []
    for action in _actions(env):
        state = env.step(state, jnp.asarray(action))
        assert not np.asarray(state.terminated | state.truncated).any()  # one episode throughout
        qpos.append(np.asarray(state.data.qpos))
        ctrl.append(np.asarray(state.data.ctrl))
    return np.stack(qpos), np.stack(ctrl), *start


def _mujoco(env: MjxEnv, qpos0: np.ndarray, qvel0: np.ndarray, ctrl: np.ndarray) -> np.ndarray:
    """qpos (STEPS, nq) of MuJoCo on the CPU (float64) from (qpos0, qvel0) applying the controls `ctrl` (STEPS, nu)."""
    data = mujoco.MjData(env.model)
    data.qpos, data.qvel = qpos0, qvel0
    qpos = []
    for controls in ctrl:
        data.ctrl = controls
        mujoco.mj_step(env.model, data, nstep=env.task.frame_skip)
        qpos.append(data.qpos.copy())
    return np.stack(qpos)


# Ant on ant.xml, not the training variant ant_mjx.xml: that one's Newton solver stops after 1 iteration, where
# the two implementations' unconverged contact forces part by 0.28 within 3 steps of landing (measured)
MODELS = {"ant_locomotion": "ant/ant.xml"}


# the full suite only (25 s for Ant, the cheapest, on 2 cores): the fast tier steps Warp in test_cameras.py. The
# arm: test_randomization.py's pick-and-place, its randomized scene on MuJoCo (CPU), MJX-JAX and Warp
@pytest.mark.slow
@pytest.mark.parametrize("task", ["ant_locomotion", "trileg_locomotion"])
def test_warp_steps_a_task_like_jax_and_mujoco(task: str) -> None:
    jax_env = make_mjx_env(task, ENVS, model_path=MODELS.get(task))
    warp_env = make_mjx_env(task, ENVS, model_path=MODELS.get(task), physics=Physics("warp"))
    jax_qpos, ctrl, qpos0, qvel0 = _rollout(jax_env)
    warp_qpos, warp_ctrl, warp_qpos0, _ = _rollout(warp_env)
    unit = _unit_quaternions
    np.testing.assert_allclose(unit(jax_env.model, warp_qpos0), unit(jax_env.model, qpos0), atol=1e-6)  # same draws
    np.testing.assert_allclose(warp_ctrl, ctrl, atol=1e-5)
    np.testing.assert_allclose(warp_qpos, jax_qpos, atol=JAX_WARP_TOL)
    cpu_qpos = _mujoco(jax_env, qpos0, qvel0, ctrl[:, 0])
    cpu_tol = CPU_TOL_OF.get(task, CPU_TOL)
    np.testing.assert_allclose(jax_qpos[:, 0], cpu_qpos, atol=cpu_tol)
    np.testing.assert_allclose(warp_qpos[:, 0], cpu_qpos, atol=cpu_tol)
    assert np.abs(jax_qpos[-1] - jax_qpos[0]).max() > 10 * JAX_WARP_TOL  # the task moved: the check can fail


@pytest.mark.slow
def test_warp_spreads_environments_over_two_devices_like_one(
    on_two_cpu_devices: Callable[[str], subprocess.CompletedProcess[str]],
) -> None:
    """Each device steps its own share with its own contact arrays and counters (MjxEnv._on_each_device): the
    same states as on one device, PPO trains, an overflow on either device is reported once, and the process
    exits with steps still in flight."""
    script = textwrap.dedent(
        """
        import jax, jax.numpy as jnp, numpy as np
        from joshua_mjx import Physics, make_mjx_env
        from joshua_ppo.settings import NetworkSettings, OptimizationSettings, ReturnSettings, RolloutSettings
        from joshua_ppo.train import train_ppo
        assert len(jax.devices()) == 2
        def run(devices, physics, steps):
            env = make_mjx_env("ant_locomotion", 4, model_path="ant/ant_mjx.xml", devices=devices, physics=physics)
            state = env.reset(jax.random.PRNGKey(3))
            for _ in range(steps):  # Ant lands on its feet after about 8 steps
                state = env.redraw_starts(jax.device_put(env.step(state, jnp.full((4, 8), 0.3)), env.sharding))
            return env, state
        qpos = []
        for devices in (jax.devices()[:1], jax.devices()):
            env, state = run(devices, Physics("warp"), 3)
            qpos.append(np.asarray(state.data.qpos))
            print("contact counters", state.data._impl.nacon.shape, flush=True)
        print("max difference", float(np.abs(qpos[0] - qpos[1]).max()), flush=True)
        reports = []
        train_ppo(env, rollout=RolloutSettings(5, 1), returns=ReturnSettings(),
                  optimization=OptimizationSettings(num_epochs=1, minibatch_size=10),
                  network=NetworkSettings(hidden_sizes=(16,)), total_timesteps=40,
                  on_progress=lambda report, state: reports.append(report))
        print("losses finite", all(np.isfinite(r.metrics["loss"]) for r in reports), len(reports), flush=True)
        env, state = run(jax.devices(), Physics("warp", nconmax=1), 12)  # 1 contact per environment: too few
        print("most contacts", int(np.asarray(state.data._impl.nacon).max()), flush=True)
        for _ in range(12):  # left in flight: the process still exits (it hung 3 times in 4 before
            state = env.step(state, jnp.zeros((4, 8)))  # impl._finish_warp_calls_at_exit)
        """
    )
    done = on_two_cpu_devices(script)
    lines = done.stdout.splitlines()
    assert "contact counters (1,)" in lines and "contact counters (2,)" in lines, done.stdout
    difference = float(next(line for line in lines if line.startswith("max difference")).split()[-1])
    assert difference < 1e-5, done.stdout
    assert "losses finite True 2" in lines, done.stdout
    assert "most contacts 2" in lines, done.stdout  # each device's 2 environments filled their shared capacity
    warnings = [line for line in done.stderr.splitlines() if "MuJoCo Warp dropped contacts" in line]
    assert len(warnings) == 1 and "raise training.mjx.nconmax (now 1)" in warnings[0], done.stderr[-3000:]


MEMORY_PROBE = """
import os, sys
import jax
from joshua_mjx import Physics
if sys.argv[1] == "started":
    jax.devices()
Physics(sys.argv[2]).leave_memory_to_warp()
print(os.environ.get("XLA_PYTHON_CLIENT_PREALLOCATE", "unset"))
"""


@pytest.mark.parametrize(
    ("impl", "backend", "preset", "expected"),
    [
        ("warp", "not started", None, "false"),  # JAX will allocate on demand, leaving Warp the rest
        ("warp", "not started", "true", "true"),  # the user's choice stands
        ("warp", "started", None, "unset"),  # too late to change: on a GPU it warns (the CPU has no pool)
        ("jax", "not started", None, "unset"),  # MJX-JAX keeps JAX's default
    ],
)
def test_warp_leaves_gpu_memory_unless_jax_started_or_the_user_chose(
    impl: str, backend: str, preset: str | None, expected: str
) -> None:
    env = {key: value for key, value in os.environ.items() if not key.startswith("XLA_PYTHON_CLIENT_")}
    if preset is not None:
        env["XLA_PYTHON_CLIENT_PREALLOCATE"] = preset
    done = subprocess.run(
        [sys.executable, "-c", MEMORY_PROBE, backend, impl], env=env, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == expected
