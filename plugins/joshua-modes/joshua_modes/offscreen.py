"""OFFSCREEN mode and its Python API: render a trajectory replay (or the model at rest) without a display.

`run_offscreen(...)` returns every frame as a list; `iter_offscreen_frames(...)` yields them one at a
time so that a long run can be written to disk with bounded memory. The mode writes an MP4 and/or a PNG
sequence (and optionally depth and segmentation images) to the output folder.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from joshua_render import choose_headless_gl

choose_headless_gl()  # the modes import mujoco here first: a MUJOCO_GL it cannot import with is disabled

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from numpy.typing import NDArray  # noqa: E402

from joshua_core.atomic import staged_outputs  # noqa: E402
from joshua_core.config_pb2 import SimulationConfig  # noqa: E402
from joshua_core.defaults import DEFAULT_SIMULATION_BACKEND  # noqa: E402
from joshua_core.errors import ConfigError, UsageError  # noqa: E402
from joshua_core.headless import warn_no_web_page  # noqa: E402
from joshua_core.interfaces import DEFAULT_RENDER_HEIGHT, DEFAULT_RENDER_WIDTH, Engine, Mode, render_size  # noqa: E402
from joshua_core.plugins import PluginHost  # noqa: E402
from joshua_core.progress import progress_bar  # noqa: E402
from joshua_core.resources import resolve_data_path  # noqa: E402
from joshua_core.run_context import RunContext  # noqa: E402
from joshua_core.trajectory_sources import load_trajectory  # noqa: E402
from joshua_modes.options_pb2 import OffscreenOptions, ReplayOptions  # noqa: E402
from joshua_modes.replay import Replayer, model_joint_ranges  # noqa: E402
from joshua_modes.validation import validate, validated_replayer  # noqa: E402
from joshua_render import VideoWriter, camera_id, create_renderer, write_png  # noqa: E402

DEFAULT_FPS = 30.0
DEFAULT_DURATION_S = 5.0  # rendered when there is no trajectory: the model at its keyframe under physics
MAX_FRAMES = 10_000_000  # frames one render may have: 3.8 days of video at 30 fps
VIDEO_NAME = "offscreen.mp4"
REPORT_NAME = "offscreen_report.json"


class FrameRenderer:
    """Renders RGB, and on request depth and segmentation, of one camera; shadows can be switched off."""

    def __init__(
        self, model: mujoco.MjModel, width: int, height: int, *, camera: str | None = None, shadows: bool = True
    ) -> None:
        self.camera = camera_id(model, camera)
        self.shadows = shadows
        self._renderer = create_renderer(model, width, height)

    def _update(self, data: mujoco.MjData) -> None:
        self._renderer.update_scene(data, camera=self.camera)
        self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = self.shadows

    def rgb(self, data: mujoco.MjData) -> NDArray[np.uint8]:
        """(H, W, 3) uint8 RGB image."""
        self._update(data)
        return self._renderer.render()

    def depth_mm(self, data: mujoco.MjData) -> NDArray[np.uint16]:
        """(H, W) uint16 depth in millimetres (65535: 65.5 m or farther)."""
        self._renderer.enable_depth_rendering()
        try:
            self._update(data)
            metres = self._renderer.render()
        finally:
            self._renderer.disable_depth_rendering()
        return np.clip(np.rint(metres * 1000.0), 0, 65535).astype(np.uint16)

    def segmentation(self, data: mujoco.MjData) -> NDArray[np.uint16]:
        """(H, W) uint16 geom id + 1 of each pixel; 0 where no geom is seen."""
        self._renderer.enable_segmentation_rendering()
        try:
            self._update(data)
            ids = self._renderer.render()
        finally:
            self._renderer.disable_segmentation_rendering()
        is_geom = ids[..., 1] == mujoco.mjtObj.mjOBJ_GEOM
        return np.where(is_geom, ids[..., 0] + 1, 0).astype(np.uint16)

    def close(self) -> None:
        self._renderer.close()


def frame_times(start: float, end: float, fps: float) -> NDArray[np.float64]:
    """Times from `start` to `end` (inclusive, within a microsecond) one 1/fps apart. More than MAX_FRAMES
    is a ConfigError: each field may be within its bounds while their product (duration x fps / speed)
    would exhaust memory before the first frame."""
    frames = (end - start) * fps
    if not frames < MAX_FRAMES:  # also NaN
        raise ConfigError(
            f"{end - start:g} s at {fps:g} frames per second of replayed time is {frames:.3g} frames, more than "
            f"{MAX_FRAMES:,}: shorten the duration or lower the fps (or raise simulation.replay.speed)"
        )
    count = math.floor(frames + 1e-6) + 1
    return start + np.arange(count) / fps


def iter_offscreen_frames(
    model_path: str | Path,
    trajectory_path: str | Path,
    width: int = DEFAULT_RENDER_WIDTH,
    height: int = DEFAULT_RENDER_HEIGHT,
    *,
    camera: str | None = None,
    fps: float = DEFAULT_FPS,
    keyframe: str | None = None,
    tracked: bool = False,
    shadows: bool = True,
    episode: int = 0,
    plugins: PluginHost,
    backend: str = DEFAULT_SIMULATION_BACKEND,
) -> Iterator[NDArray[np.uint8]]:
    """Yield (height, width, 3) uint8 frames of the trajectory replayed kinematically (or `tracked`),
    one per 1/fps of trajectory time. Rows with a bad timestamp or a non-finite value are skipped.

    Relative paths resolve like config paths: the working directory, then the shipped models folder. `plugins`
    (the run's host) reads models and trajectories in other formats (USD, a LeRobot dataset) and provides the
    engine, from the backend named `backend` (as `simulation.backend` names it for the mode).
    """
    engine = plugins.backend(backend).create_engine(Path(model_path), plugins, render_width=width, render_height=height)
    with engine:
        engine.reset(keyframe)
        path = resolve_data_path(trajectory_path, what="trajectory", folders=True)
        trajectory = load_trajectory(path, model_joint_ranges(engine.model), episode=episode, plugins=plugins)
        _, usable = validate(trajectory, engine.model, engine.data.qpos.copy())
        replayer = Replayer(engine, trajectory, usable, tracked=tracked)
        renderer = FrameRenderer(engine.model, width, height, camera=camera, shadows=shadows)
        try:
            for t in frame_times(replayer.start_time, replayer.end_time, fps):
                replayer.show(t)
                yield renderer.rgb(engine.data)
        finally:
            renderer.close()


def run_offscreen(
    model_path: str | Path,
    trajectory_path: str | Path,
    width: int = DEFAULT_RENDER_WIDTH,
    height: int = DEFAULT_RENDER_HEIGHT,
    *,
    camera: str | None = None,
    fps: float = DEFAULT_FPS,
) -> list[NDArray[np.uint8]]:
    """All frames of the trajectory's kinematic replay as (height, width, 3) uint8 arrays.

    For long trajectories prefer `iter_offscreen_frames`, which holds one frame at a time. A top-level entry
    point, so it finds the installed plugins itself.
    """
    plugins = PluginHost.discover()
    return list(
        iter_offscreen_frames(model_path, trajectory_path, width, height, camera=camera, fps=fps, plugins=plugins)
    )


@dataclass(frozen=True)
class OffscreenOutputs:
    """Where OFFSCREEN writes, inside the output folder."""

    root: Path

    @property
    def video(self) -> Path:
        return self.root / VIDEO_NAME

    @property
    def frames(self) -> Path:
        return self.root / "offscreen_frames"

    @property
    def depth(self) -> Path:
        return self.root / "offscreen_depth"

    @property
    def segmentation(self) -> Path:
        return self.root / "offscreen_segmentation"


class OffscreenMode(Mode):
    """Renders the trajectory replay (or, without a trajectory, `duration` seconds of physics) to files.

    The report, the video and the image folders of one render are written into a hidden folder inside the
    output folder and moved into place together once complete (`staged_outputs`): a render stopped part way
    (even killed) leaves the earlier render's outputs as they were, never a mix of two renders."""

    def run(self, config: SimulationConfig, context: RunContext) -> None:
        warn_no_web_page(config, "OFFSCREEN")
        options: OffscreenOptions = context.settings("offscreen", config)
        replay: ReplayOptions = context.settings("replay", config)
        fps = options.fps or DEFAULT_FPS
        width, height = render_size(config)
        outputs = OffscreenOutputs(context.output_dir)
        with staged_outputs(context.output_dir) as staging, context.create_engine(config) as engine:
            renderer = FrameRenderer(
                engine.model,
                width,
                height,
                camera=options.camera or None,
                shadows=options.shadows if options.HasField("shadows") else True,
            )
            try:
                try:
                    advance, times = self._timeline(config, replay, engine, context, fps, staging.temporary)
                except UsageError:
                    staging.publish()  # the report of a refused replay says why nothing was rendered
                    raise
                written = self._render(options, renderer, engine, advance, times, fps, outputs, staging.temporary)
                staging.publish()
            finally:
                renderer.close()
        print(f"rendered {len(times)} frames of {width}x{height} at {fps:g} fps; wrote {', '.join(written)}")

    @staticmethod
    def _timeline(
        config: SimulationConfig,
        replay: ReplayOptions,
        engine: Engine,
        context: RunContext,
        fps: float,
        staging: Path,
    ) -> tuple[Replayer | None, NDArray[np.float64]]:
        """The replayer (None: plain physics) of the trajectory, validated as `replay` says, and the times of the
        frames; the validation report goes into `staging`."""
        if not config.trajectory_path:
            return None, frame_times(0.0, config.duration or DEFAULT_DURATION_S, fps)
        replayer, _ = validated_replayer(
            config,
            engine,
            context.output_dir / REPORT_NAME,
            replay=replay,
            refusal="nothing rendered because simulation.replay.strict is set",
            plugins=context.plugins,
            staged_at=staging / REPORT_NAME,
        )
        return replayer, frame_times(replayer.start_time, replayer.end_time, fps)

    @staticmethod
    def _render(
        options: OffscreenOptions,
        renderer: FrameRenderer,
        engine: Engine,
        replayer: Replayer | None,
        times: NDArray[np.float64],
        fps: float,
        outputs: OffscreenOutputs,
        staging: Path,
    ) -> list[str]:
        """Render every frame time to the requested files, written into `staging`; returns where they will be
        (`outputs`) once published. Each PNG folder replaces the earlier one whole: a render that is shorter or of
        another size never leaves old frames among new ones."""
        final, outputs = outputs, OffscreenOutputs(staging)
        want_video = options.output in (OffscreenOptions.MP4, OffscreenOptions.MP4_AND_PNG)
        want_png = options.output in (OffscreenOptions.PNG, OffscreenOptions.MP4_AND_PNG)
        with contextlib.ExitStack() as stack:
            video = stack.enter_context(VideoWriter(outputs.video, fps)) if want_video else None
            wanted = [folder for folder, on in _folders(outputs, want_png, options) if on]
            for folder in wanted:
                folder.mkdir()
            bar = stack.enter_context(progress_bar(len(times), description="offscreen", unit="frames"))
            for index, t in enumerate(times):
                if replayer is not None:
                    replayer.show(t)
                else:
                    engine.step(max(0, round((t - engine.time) / engine.timestep)))
                rgb = renderer.rgb(engine.data)
                name = f"frame_{index:06d}.png"
                if video is not None:
                    video.write(rgb)
                if want_png:
                    write_png(outputs.frames / name, rgb)
                if options.depth:
                    write_png(outputs.depth / name, renderer.depth_mm(engine.data))
                if options.segmentation:
                    write_png(outputs.segmentation / name, renderer.segmentation(engine.data))
                bar.update(1)
        written = [str(final.video)] if want_video else []
        written += [f"{folder}/" for folder, on in _folders(final, want_png, options) if on]
        return written


def _folders(outputs: OffscreenOutputs, want_png: bool, options: OffscreenOptions) -> list[tuple[Path, bool]]:
    return [(outputs.frames, want_png), (outputs.depth, options.depth), (outputs.segmentation, options.segmentation)]
