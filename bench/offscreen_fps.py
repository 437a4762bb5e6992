"""Headless rendering speed of the SO-ARM100 scene at 640x480, with and without shadows, in one run.

For each shadow setting it times three variants on the same poses of the example trajectory:
  raw       mujoco.Renderer.update_scene + render (the reference),
  frames    joshua_modes' FrameRenderer.rgb (what run_offscreen and OFFSCREEN use),
  pipeline  the kinematic replay step + FrameRenderer.rgb + MP4 encoding (VideoWriter).
The variants alternate frame by frame; per frame the fastest of several runs counts. It prints frames/s, the ratio of
FrameRenderer to raw (target <= 1.05: the wrapper adds nothing measurable), and the GL platform.
Without a GPU, EGL renders with Mesa's llvmpipe on the CPU, so the numbers scale with CPU cores.

Usage: python bench/offscreen_fps.py [--frames N] [--repeats R] [--width W --height H]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

from joshua_core.resources import models_dir
from joshua_core.trajectory import read_trajectory
from joshua_modes.offscreen import FrameRenderer, frame_times
from joshua_modes.replay import Replayer, model_joint_names
from joshua_mujoco import MuJoCoEngine
from joshua_render import VideoWriter, create_renderer

TARGET_RATIO = 1.05


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=60, help="frames per timed run")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    args = parser.parse_args()

    engine = MuJoCoEngine("so_arm100/scene.xml", render_width=args.width, render_height=args.height)
    engine.reset("home")
    trajectory = read_trajectory(
        models_dir() / "trajectories" / "so_arm100_example.csv", model_joint_names(engine.model)
    )
    replayer = Replayer(engine, trajectory)
    times = frame_times(replayer.start_time, replayer.end_time, args.frames / replayer.duration)[: args.frames]
    print(
        f"SO-ARM100 scene, {args.width}x{args.height}, camera '{engine.model.camera(0).name}', "
        f"{len(times)} frames per run, best of {args.repeats}; MUJOCO_GL={os.environ.get('MUJOCO_GL', '(unset)')}"
    )
    with tempfile.TemporaryDirectory() as folder:
        for shadows in (True, False):
            variants, close = make_loops(engine, replayer, shadows, Path(folder) / "bench.mp4")
            best = best_of(variants, times, args.repeats)
            close()
            fps = {name: len(times) / seconds for name, seconds in best.items()}
            ratio = best["frames"] / best["raw"]
            verdict = "ok" if ratio <= TARGET_RATIO else "OVER TARGET"
            print(
                f"shadows {'on ' if shadows else 'off'}: raw {fps['raw']:7.1f} frames/s | FrameRenderer "
                f"{fps['frames']:7.1f} frames/s (ratio {ratio:.3f}, target <= {TARGET_RATIO}: {verdict}) | "
                f"with replay + MP4 {fps['pipeline']:7.1f} frames/s"
            )
    engine.close()


def make_loops(
    engine: MuJoCoEngine, replayer: Replayer, shadows: bool, video_path: Path
) -> tuple[dict[str, Callable[[float], None]], Callable[[], None]]:
    """One frame of each timed variant for one shadow setting, and a function that releases them."""
    width, height = engine.render_width, engine.render_height
    raw_renderer = create_renderer(engine.model, width, height)
    frames = FrameRenderer(engine.model, width, height, shadows=shadows)
    video = VideoWriter(video_path, fps=30.0)

    def raw(t: float) -> None:
        replayer.show(t)
        raw_renderer.update_scene(engine.data, camera=0)
        raw_renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows
        raw_renderer.render()

    def wrapped(t: float) -> None:
        replayer.show(t)
        frames.rgb(engine.data)

    def pipeline(t: float) -> None:
        replayer.show(t)
        video.write(frames.rgb(engine.data))

    def close() -> None:
        video.close()
        raw_renderer.close()
        frames.close()

    return {"raw": raw, "frames": wrapped, "pipeline": pipeline}, close


def best_of(variants: dict[str, Callable[[float], None]], times: NDArray[np.float64], repeats: int) -> dict[str, float]:
    """Seconds each variant takes for all `times`: per frame the fastest of `repeats` runs, summed.

    The variants alternate frame by frame, so a load spike from other processes on the machine hits
    them alike instead of one whole loop.
    """
    for variant in variants.values():  # warm-up: renderer buffers, codec
        variant(float(times[0]))
    fastest = {name: np.full(len(times), np.inf) for name in variants}
    for _ in range(repeats):
        for index, t in enumerate(times):
            for name, variant in variants.items():
                start = time.perf_counter()
                variant(float(t))
                fastest[name][index] = min(fastest[name][index], time.perf_counter() - start)
    return {name: float(seconds.sum()) for name, seconds in fastest.items()}


if __name__ == "__main__":
    main()
