"""Camera rendering throughput of the MJX environments on MuJoCo Warp: frames/s and env steps/s with a camera
against the same environments without one, in one process (so the ratios compare like with like).

    python bench/mjx_render_throughput.py                                   # one GPU: 64x64, 128x128; 1024-8192
    python bench/mjx_render_throughput.py --sizes 64 --num-envs 4096 --kind depth
    python bench/mjx_render_throughput.py --smoke                           # tiny, on CPU

For each batch size, after compilation (best of three timed calls, bench/mjx_time_to_target.best_rate):
- `env_steps_no_camera`: env steps/s of `MjxEnv.step` under uniform random actions, the task without cameras;
- per image size, the task with the camera rendering on every step (TaskConfig.cameras):
  `env_steps_<size>` env steps/s of the same step, `ratio_<size>` its share of the camera-less rate, and
  `frames_<size>` frames/s of the renderer alone (`refit_bvh` + `render` on the batch, unpacked to the image);
  `image_mb_<size>`: the images the EnvState keeps, in MB (the current frame only).
Each rendered frame is one camera's image of one environment, so frames/s of the step equals env steps/s here.
"""

from __future__ import annotations

import argparse
import json
from typing import Any

import jax
from mjx_time_to_target import best_rate, environment, environment_rate, load_config

from joshua_core.config_pb2 import CameraConfig
from joshua_core.plugins import PluginHost
from joshua_mjx import Physics
from joshua_mjx.env import MjxEnv
from joshua_mjx.impl import WARP


def render_rate(env: MjxEnv, calls: int) -> float:
    """Frames/s of the environments' cameras alone: `calls` renders of the reset state's batch per timed call."""
    state = env.reset(jax.random.PRNGKey(0))
    fields = env.randomization.model_params(state.params)

    def render(_: int, data: Any) -> Any:
        return env.cameras.render(lambda f, d: env._physics(f, fields, d), data)[1]

    run = jax.jit(lambda data: jax.lax.fori_loop(0, calls, render, data))
    return best_rate(run, state.data, calls * env.num_envs * len(env.cameras.cameras))[1]


def with_camera(config: Any, camera: str, size: int, kind: str) -> Any:
    """A copy of the training config whose task renders `camera` at size x size (`kind`) on every step."""
    config = type(config).FromString(config.SerializeToString())
    kind_value = CameraConfig.Kind.Value(kind.upper())
    config.task_config.cameras.add(camera=camera, width=size, height=size, kind=kind_value)
    return config


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", default="so_arm100_pick_place_mjx", help="a preset's name or a .pbtxt file")
    parser.add_argument("--camera", default="overview", help="the scene's camera to render")
    parser.add_argument("--kind", choices=["rgb", "depth", "segmentation"], default="rgb")
    parser.add_argument("--sizes", type=int, nargs="+", default=[64, 128], help="image sides in pixels")
    parser.add_argument("--num-envs", type=int, nargs="+", default=[1024, 2048, 4096, 8192])
    parser.add_argument("--steps", type=int, default=20, help="env steps (or renders) per timed call")
    parser.add_argument("--smoke", action="store_true", help="tiny sizes (CPU): 4 envs, 16x16, 2 steps")
    args = parser.parse_args()
    if args.smoke:
        args.num_envs, args.sizes, args.steps = [4], [16], 2
    plugins = PluginHost.discover()
    Physics(WARP).leave_memory_to_warp()  # before jax.devices() starts JAX's backends
    devices = jax.devices()[:1]  # MuJoCo Warp steps one device's environments
    results = []
    for num_envs in args.num_envs:
        config = load_config(args.preset, ["training.mjx.impl=WARP"], num_envs, plugins.options())
        plain = environment_rate(environment(config, plugins, num_envs, devices), args.steps)
        entry: dict[str, Any] = {"num_envs": num_envs, "env_steps_no_camera": plain}
        for size in args.sizes:
            env = environment(with_camera(config, args.camera, size, args.kind), plugins, num_envs, devices)
            stepped = environment_rate(env, args.steps)
            entry[f"env_steps_{size}"] = stepped
            entry[f"ratio_{size}"] = stepped / plain
            entry[f"frames_{size}"] = render_rate(env, args.steps)
            entry[f"image_mb_{size}"] = env.cameras.bytes_per_env * num_envs / 1e6
            del env
        results.append(entry)
        print(json.dumps(entry), flush=True)
    device = jax.devices()[0].device_kind
    for entry in results:
        line = "  ".join(f"{key} {value:,.3g}" for key, value in entry.items() if isinstance(value, float))
        print(f"{args.preset} {args.camera} {args.kind} on {device}, {entry['num_envs']} envs: {line}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
