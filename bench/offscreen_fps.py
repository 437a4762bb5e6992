"""Headless rendering speed of the SO-ARM100 scene at 640x480, with and without shadows, in one run.

For each shadow setting it times three loops over the same poses of the example trajectory:
  raw       mujoco.Renderer.update_scene + render (the reference),
  frames    joshua_modes' FrameRenderer.rgb (what run_offscreen and OFFSCREEN use),
  pipeline  the kinematic replay step + FrameRenderer.rgb + MP4 encoding (VideoWriter).
Each loop runs several times, interleaved; the fastest run counts. It prints frames/s, the ratio of
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
from joshua_modes.offscreen import FrameRenderer, frame_times
from joshua_modes.replay import Replayer, model_joint_names
from joshua_modes.trajectory import read_trajectory
from joshua_modes.video import VideoWriter
from joshua_mujoco import MuJoCoEngine
from joshua_mujoco.engine import create_renderer

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
            loops, close = make_loops(engine, replayer, times, shadows, Path(folder) / "bench.mp4")
            best = best_of(loops, args.repeats)
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
    engine: MuJoCoEngine, replayer: Replayer, times: NDArray[np.float64], shadows: bool, video_path: Path
) -> tuple[dict[str, Callable[[], None]], Callable[[], None]]:
    """The three timed loops for one shadow setting, and a function that releases their renderers."""
    width, height = engine.render_width, engine.render_height
    raw_renderer = create_renderer(engine.model, width, height)
    frames = FrameRenderer(engine.model, width, height, shadows=shadows)

    def raw() -> None:
        for t in times:
            replayer.show(t)
            raw_renderer.update_scene(engine.data, camera=0)
            raw_renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows
            raw_renderer.render()

    def wrapped() -> None:
        for t in times:
            replayer.show(t)
            frames.rgb(engine.data)

    def pipeline() -> None:
        with VideoWriter(video_path, fps=30.0) as video:
            for t in times:
                replayer.show(t)
                video.write(frames.rgb(engine.data))

    def close() -> None:
        raw_renderer.close()
        frames.close()

    return {"raw": raw, "frames": wrapped, "pipeline": pipeline}, close


def best_of(loops: dict[str, Callable[[], None]], repeats: int) -> dict[str, float]:
    """Fastest of `repeats` interleaved runs of each loop, in seconds (after one warm-up run each)."""
    for loop in loops.values():
        loop()
    best = {name: float("inf") for name in loops}
    for _ in range(repeats):
        for name, loop in loops.items():
            start = time.perf_counter()
            loop()
            best[name] = min(best[name], time.perf_counter() - start)
    return best


if __name__ == "__main__":
    main()
