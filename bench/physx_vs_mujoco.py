"""PhysX against MuJoCo: env steps/s of the Isaac Ant task on the usd backend, every engine in one run.

    python bench/physx_vs_mujoco.py                                   # CPU: PhysX and mujoco.batch, 256 envs
    python bench/physx_vs_mujoco.py --engines physx-jax mjx-warp --envs 8192 16384   # GPU machine

Engines: `mujoco` (mujoco.batch on the CPU's cores) and `physx` (ovphysx: CPU PhysX here, GPU PhysX where
CUDA is present) are the usd backend's NUMPY environments, stepped from Python with open-loop controls;
`physx-jax` (the same PhysX, its state on the device where JAX runs), `mjx-jax` and `mjx-warp` (MJX with either
implementation) are its JAX environments, stepped in a compiled loop of the same controls, so the task's terms
run on the device and no state crosses to the host. Every rate is after the first steps (compilation, warm-up).
At the first size it also prints how far every pair of engines' joint trajectories drift apart under the same
controls from the same start, per joint too (sim-to-sim).
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.interfaces import EnvKind, EnvSpec
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_mujoco.vector import task_config_from_options
from joshua_usd.options_pb2 import UsdOptions, usd

NO_RESET_NOISE = {"reset_joints_uniform": {"weight": 0}, "reset_qvel_normal": {"weight": 0}}
ENGINES = ("mujoco", "physx", "physx-jax", "mjx-jax", "mjx-warp")
JAX_ENGINES = ("physx-jax", "mjx-jax", "mjx-warp")
WARMUP_STEPS = 10  # stepped before timing: PhysX's first steps and the compiled loop's first call


def make(plugins: PluginHost, engine: str, num_envs: int) -> Any:
    """The Isaac Ant environments of `engine` (see the module docstring), `num_envs` of them."""
    training = TrainingConfig()
    if engine.startswith("physx"):
        training.Extensions[usd].physics = UsdOptions.PHYSX
    if engine.startswith("mjx-"):
        from joshua_mjx.options_pb2 import MjxOptions
        from joshua_mjx.options_pb2 import mjx as mjx_options

        training.Extensions[mjx_options].impl = MjxOptions.Impl.Value(engine[4:].upper())
    spec = EnvSpec(
        "isaac_ant_locomotion",
        num_envs,
        model_path=resolve_data_path("isaac/ant.usd"),
        task_config=task_config_from_options({"terms": NO_RESET_NOISE}),
        training=training,
    )
    kind = EnvKind.JAX if engine in JAX_ENGINES else EnvKind.NUMPY
    return plugins.backend("usd").create_envs(spec, kind, plugins)


def controls(steps: int, num_envs: int) -> np.ndarray:
    """(steps, num_envs, 8) open-loop controls: a sine per joint, the same in every environment."""
    return np.sin(np.arange(steps)[:, None, None] * 0.2 + np.arange(8)) * np.ones((1, num_envs, 1))


def step_numpy(env: Any, actions: np.ndarray) -> tuple[float, np.ndarray]:
    """Env steps/s of `actions` after WARMUP_STEPS of them, and environment 0's joint angles at every step."""
    env.reset(seed=0)
    joints = []
    for action in actions[:WARMUP_STEPS]:
        env.step(action)
        joints.append(env.qpos[0, 7:].copy())
    start = time.perf_counter()
    for action in actions[WARMUP_STEPS:]:
        env.step(action)
        joints.append(env.qpos[0, 7:].copy())
    seconds = time.perf_counter() - start
    return (len(actions) - WARMUP_STEPS) * actions.shape[1] / seconds, np.array(joints)


def step_jax(env: Any, actions: np.ndarray) -> tuple[float, np.ndarray]:
    """Env steps/s of `actions` stepped in one compiled loop (timed on its second call), and environment 0's joint
    angles at every step."""
    import jax

    def body(state: Any, action: jax.Array) -> tuple[Any, jax.Array]:
        state = env.step(state, action)
        return state, state.data.qpos[0, 7:]

    def run(state: Any, sequence: jax.Array) -> Any:
        return jax.lax.scan(body, state, sequence)

    loop = jax.jit(run)
    state = env.reset(jax.random.PRNGKey(0))
    sequence = jax.numpy.asarray(actions, dtype=jax.numpy.float32)
    jax.block_until_ready(loop(state, sequence))  # compiles
    start = time.perf_counter()
    _, joints = jax.block_until_ready(loop(state, sequence))
    return actions.shape[0] * actions.shape[1] / (time.perf_counter() - start), np.asarray(joints)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--engines", nargs="+", choices=ENGINES, default=["mujoco", "physx"])
    parser.add_argument("--envs", type=int, nargs="+", default=[256])
    parser.add_argument("--steps", type=int, default=200)
    args = parser.parse_args()
    plugins = PluginHost.discover()
    for size_index, num_envs in enumerate(args.envs):
        actions = controls(args.steps, num_envs)
        trajectories = {}
        for engine in args.engines:
            try:
                env = make(plugins, engine, num_envs)
                start = time.perf_counter()
                if engine in JAX_ENGINES:
                    rate, trajectories[engine] = step_jax(env, actions)
                else:
                    rate, trajectories[engine] = step_numpy(env, actions)
                    env.close()
            except Exception as error:  # one engine failing (e.g. no CUDA build) leaves the others' figures
                print(f"{engine}: {num_envs} envs failed: {type(error).__name__}: {error}", flush=True)
                continue
            seconds = time.perf_counter() - start
            print(f"{engine}: {rate:,.0f} env steps/s ({num_envs} envs, {args.steps} steps, {seconds:.1f} s in all)")
        if size_index == 0:
            print_gaps(trajectories, args.steps)


def print_gaps(trajectories: dict[str, np.ndarray], steps: int) -> None:
    """How far each pair of engines' joint trajectories (environment 0, the same controls from the same start) drift
    apart: over all joints after 10, 50 and the last step, and per joint over the whole run (sim-to-sim)."""
    names = list(trajectories)
    for i, first in enumerate(names):
        for second in names[i + 1 :]:
            gap = np.abs(trajectories[first] - trajectories[second])
            for t in (9, 49, steps - 1):
                if t < steps:
                    print(f"{first} vs {second}, step {t + 1}: joint gap mean {gap[t].mean():.3f} rad, "
                          f"max {gap[t].max():.3f} rad")  # fmt: skip
            per_joint = " ".join(f"{value:.3f}" for value in gap.mean(axis=0))
            print(f"{first} vs {second}, mean gap per joint over {steps} steps (rad): {per_joint}")


if __name__ == "__main__":
    main()
