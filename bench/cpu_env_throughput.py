"""Environment steps per second of the Ant task: JOSHUA's BatchedVectorEnv against Gymnasium's Ant-v5.

For each number of environments, in the same run and interleaved: Gymnasium's own
`gymnasium.make_vec("Ant-v5", num_envs=N)` (its synchronous vector env, one MjData per env), our
`make_vector_env("ant_locomotion", N)`, and, for context, the bare physics of the same batch
(`mujoco.batch` stepping frame_skip substeps: no task terms and no resets, so fallen ants stay
down), all from a reset and with uniform random actions; the two environments autoreset. Each is
timed `--repeats` times and the fastest run counts. Both environments simulate the Ant-v5 task:
same geometry, frame skip 5 (dt = 0.05 s), 105-d observation with contact forces, the same reward
terms and termination; but stock Ant-v5 integrates with RK4 (four force evaluations a step) and
models/ant/ant.xml with MuJoCo's default Euler, which accounts for part of the ratio.
Goal: ours / Gymnasium >= 5 at 256 environments.
Usage: python bench/cpu_env_throughput.py [--envs 1 16 256] [--seconds 1.5] [--repeats 3] [--nthread N]
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable

import numpy as np

from joshua_mujoco.vector import make_vector_env

TARGET_RATIO = 5.0
TARGET_ENVS = 256


def steps_per_second(
    step: Callable[[np.ndarray], object], actions: np.ndarray, seconds: float, prepare: Callable[[], object]
) -> float:
    """Environment steps per second of `step` over batches of random actions, run for about `seconds`."""
    num_envs = actions.shape[1]
    prepare()
    step(actions[0])  # warm up
    calls, start = 0, time.perf_counter()
    while True:
        step(actions[calls % len(actions)])
        calls += 1
        elapsed = time.perf_counter() - start
        if elapsed >= seconds:
            return calls * num_envs / elapsed


def measure(num_envs: int, seconds: float, repeats: int, nthread: int | None) -> tuple[float, float, float]:
    """Best env steps/s of (Gymnasium Ant-v5, ours, bare mujoco.batch physics) at `num_envs`."""
    import gymnasium

    reference = gymnasium.make_vec("Ant-v5", num_envs=num_envs, vectorization_mode="sync")
    ours = make_vector_env("ant_locomotion", num_envs, seed=0, nthread=nthread)
    batch, frame_skip = ours.simulation.physics.batch, ours.task.frame_skip
    ctrl = ours.simulation.ctrl

    def bare(action: np.ndarray) -> None:
        ctrl[:] = action
        batch.step(nstep=frame_skip)

    actions = np.random.default_rng(0).uniform(-1, 1, (64, num_envs, 8))
    best = [0.0, 0.0, 0.0]
    runs = ((reference.step, reference.reset), (ours.step, ours.reset), (bare, batch.reset))
    for _ in range(repeats):  # interleaved, so that changes in machine load hit all three alike
        for index, (step, prepare) in enumerate(runs):
            best[index] = max(best[index], steps_per_second(step, actions, seconds, prepare))
    reference.close()
    ours.close()
    return best[0], best[1], best[2]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--envs", type=int, nargs="+", default=[1, 16, 256])
    parser.add_argument("--seconds", type=float, default=1.5, help="length of one timed run")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--nthread", type=int, default=None, help="threads of our batch (default: one per core)")
    args = parser.parse_args()
    load = os.getloadavg()[0]
    print(f"cores: {os.cpu_count()}, load average (1 min) at start: {load:.2f}")
    columns = ("gymnasium Ant-v5", 17), ("joshua", 10), ("bare physics", 13), ("joshua/gym", 11), ("joshua/bare", 12)
    print(f"{'envs':>5}" + "".join(f" {title:>{width}}" for title, width in columns))
    for num_envs in args.envs:
        reference, ours, bare = measure(num_envs, args.seconds, args.repeats, args.nthread)
        verdict = ""
        if num_envs == TARGET_ENVS:
            verdict = "  ok" if ours / reference >= TARGET_RATIO else f"  BELOW TARGET {TARGET_RATIO:g}x"
        print(
            f"{num_envs:>5} {reference:>15,.0f}/s {ours:>8,.0f}/s {bare:>11,.0f}/s "
            f"{ours / reference:>10.1f}x {ours / bare:>11.0%}{verdict}"
        )
    print(f"load average (1 min) at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
