"""Per-step Python overhead of MuJoCoEngine.step() against raw mujoco.mj_step, measured in one run.

For the SO-ARM100 scene and the Ant, both loops step the same model from the same start state;
each is timed several times, interleaved, and the fastest run of each is compared.
Target: ratio engine / raw <= 1.10.   Usage: python bench/engine_overhead.py [--steps N] [--repeats R]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import mujoco

from joshua_mujoco import MuJoCoEngine

MODELS = {"SO-ARM100 scene": ("so_arm100/scene.xml", "home"), "Ant": ("ant/ant.xml", None)}
TARGET_RATIO = 1.10


def timed(run: Callable[[], None], reset: Callable[[], None]) -> float:
    """Seconds `run` takes, starting from the reset state."""
    reset()
    start = time.perf_counter()
    run()
    return time.perf_counter() - start


def measure(model_path: str, keyframe: str | None, steps: int, repeats: int) -> tuple[float, float]:
    """Seconds per step (raw mj_step, MuJoCoEngine.step) for one model."""
    engine = MuJoCoEngine(model_path)
    model, data = engine.model, mujoco.MjData(engine.model)
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe) if keyframe else -1

    def reset_both() -> None:
        engine.reset(keyframe)
        if key >= 0:
            mujoco.mj_resetDataKeyframe(model, data, key)
        else:
            mujoco.mj_resetData(model, data)

    def raw() -> None:
        for _ in range(steps):
            mujoco.mj_step(model, data)

    def wrapped() -> None:
        step = engine.step
        for _ in range(steps):
            step()

    raw_times, engine_times = [], []
    for _ in range(repeats):  # interleave so drift in machine load hits both alike
        raw_times.append(timed(raw, reset_both))
        engine_times.append(timed(wrapped, reset_both))
    return min(raw_times) / steps, min(engine_times) / steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=5000)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    print(f"mujoco {mujoco.__version__}; {args.steps} steps x {args.repeats} interleaved repeats, fastest taken")
    print(f"{'model':<16} {'raw mj_step':>13} {'engine.step':>13} {'ratio':>7}  target <= {TARGET_RATIO}")
    for label, (path, keyframe) in MODELS.items():
        raw, wrapped = measure(path, keyframe, args.steps, args.repeats)
        ratio = wrapped / raw
        verdict = "ok" if ratio <= TARGET_RATIO else "OVER TARGET"
        print(f"{label:<16} {raw * 1e6:>10.2f} us {wrapped * 1e6:>10.2f} us {ratio:>7.3f}  {verdict}")


if __name__ == "__main__":
    main()
