"""Demonstrations per minute of `joshua demos`' episode producers: the CPU one (mujoco.batch, one renderer) and the
GPU one (MuJoCo Warp through joshua-mjx), the scripted pick-and-place on the demos preset (randomized), for each
--num-envs.

    python bench/demos_rate.py --physics cpu gpu --num-envs 256 1024 4096     # one GPU
    python bench/demos_rate.py --physics cpu gpu --num-envs 2 --batches 1 --size 32 24   # smoke, on CPU

Per producer and batch size, one JSON line: `first_batch_s` (the first batch, compilation included),
then over --batches more batches `attempts_per_s` (attempts rolled out, failed ones included) and
`kept_per_minute` (successful ones: the episodes a dataset gets), and `success_rate`. The producers alone, without
the H.264 encoding and parquet writing of `joshua demos`, whose last line gives the whole command's episodes/minute.
"""

from __future__ import annotations

import argparse
import json
import time
from itertools import islice

from joshua_core.config import finalize, load_preset
from joshua_core.options import LENIENT
from joshua_core.plugins import PluginHost
from joshua_lerobot.demos import CPU, DEFAULT_FPS, DEFAULT_PRESET, GPU, make_producer
from joshua_lerobot.rollouts import EpisodeProducer


def rate(producer: EpisodeProducer, batches: int) -> dict[str, float]:
    """Attempts/s and kept episodes/minute over `batches` batches after a first one (compilation, warm-up)."""
    stream = producer.rollouts()
    started = time.perf_counter()
    list(islice(stream, producer.num_envs))
    first = time.perf_counter() - started
    attempts = batches * producer.num_envs
    started = time.perf_counter()
    kept = sum(rollout.success for rollout in islice(stream, attempts))
    seconds = time.perf_counter() - started
    return {
        "first_batch_s": round(first, 2),
        "attempts_per_s": round(attempts / seconds, 2),
        "kept_per_minute": round(kept / seconds * 60, 1),
        "success_rate": round(kept / attempts, 3),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--physics", choices=[CPU, GPU], nargs="+", default=[CPU, GPU])
    parser.add_argument("--num-envs", type=int, nargs="+", default=[256, 1024, 4096])
    parser.add_argument("--batches", type=int, default=3, help="timed batches after the first")
    parser.add_argument("--size", type=int, nargs=2, default=[64, 64], metavar=("W", "H"), help="frame size")
    parser.add_argument("--camera", action="append", help="recorded cameras (default: the model's first)")
    parser.add_argument("--preset", default=DEFAULT_PRESET)
    args = parser.parse_args()
    plugins = PluginHost.discover()
    training = finalize(load_preset(args.preset, LENIENT)).training
    for physics in args.physics:
        for num_envs in args.num_envs:
            options = argparse.Namespace(
                physics=physics, num_envs=num_envs, camera=args.camera, width=args.size[0], height=args.size[1],
                fps=DEFAULT_FPS, seed=None,
            )  # fmt: skip
            producer = make_producer(options, training, plugins)
            try:
                result = rate(producer, args.batches)
            finally:
                producer.close()
            print(json.dumps({"physics": physics, "num_envs": num_envs, "size": args.size, **result}), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
