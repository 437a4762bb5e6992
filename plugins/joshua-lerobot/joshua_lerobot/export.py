"""`joshua lerobot-export`: trajectories (CSVs or dataset episodes) replayed on a model, its cameras rendered
headless, written as a LeRobot dataset of one episode per trajectory: observation.state = the replayed joint positions,
action = the trajectory's targets (`<joint>.target` columns, a dataset's action) where it has them, else
the positions themselves (a scripted trajectory is its own command)."""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from joshua_core.cli import add_config_arguments, load
from joshua_core.config import finalize
from joshua_core.config_pb2 import SimulationConfig
from joshua_core.defaults import DEFAULT_OUTPUT_DIR
from joshua_core.errors import UsageError
from joshua_core.interfaces import Command
from joshua_core.limits import MAX_FPS, MAX_IMAGE_SIDE, MIN_FPS, MIN_IMAGE_SIDE, cli_number
from joshua_core.options import sub_message
from joshua_core.outputs import check_replaceable
from joshua_core.plugins import PluginHost
from joshua_core.progress import progress_bar
from joshua_core.resources import resolve_data_path
from joshua_core.trajectory import Trajectory
from joshua_core.trajectory_sources import load_trajectory
from joshua_lerobot.joints import (
    DEFAULT_UNITS,
    LeRobotUnits,
    TopicMapping,
    add_units_arguments,
    joint_offsets,
    units_from_arguments,
)
from joshua_lerobot.writer import DatasetEpisode, write_dataset

DEFAULT_MODEL = "so_arm100/scene.xml"
DEFAULT_FPS = 30
DEFAULT_WIDTH, DEFAULT_HEIGHT = 320, 240
DEFAULT_TASK = "replay"
DEFAULT_OUT = Path(DEFAULT_OUTPUT_DIR) / "lerobot_dataset"


def add_camera_arguments(parser: argparse.ArgumentParser) -> None:
    """The dataset's cameras and video size, as every command that writes a LeRobot dataset takes them: `--camera`
    (repeatable; None: the model's first), `--width` and `--height` (even: yuv420p, `video.check_frame_size`)."""
    parser.add_argument(
        "--camera",
        action="append",
        default=None,
        help="a model camera recorded as observation.images.<camera> (repeatable; default: the model's first)",
    )
    for side, default in (("width", DEFAULT_WIDTH), ("height", DEFAULT_HEIGHT)):
        parser.add_argument(
            f"--{side}",
            type=cli_number(f"--{side}", MIN_IMAGE_SIDE, MAX_IMAGE_SIDE, integer=True),
            default=default,
            help=f"video {side} (default {default}; even)",
        )


class LeRobotExportCommand(Command):
    """Writes a rendered replay of a trajectory as a LeRobot dataset."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument(
            "trajectory", nargs="+", help="trajectory CSVs or LeRobot dataset folders (see --episode): one episode each"
        )
        parser.add_argument("--model", default=DEFAULT_MODEL, help=f"model to replay on (default {DEFAULT_MODEL})")
        parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"dataset folder (default {DEFAULT_OUT})")
        parser.add_argument(
            "--overwrite", action="store_true", help="replace the --out folder when joshua wrote it (a dataset)"
        )
        parser.add_argument(
            "--fps",
            type=cli_number("--fps", MIN_FPS, MAX_FPS, integer=True),
            default=DEFAULT_FPS,
            help=f"frames per second (default {DEFAULT_FPS})",
        )
        add_camera_arguments(parser)
        parser.add_argument("--no-video", action="store_true", help="write joint data only, no camera video")
        parser.add_argument(
            "--task",
            action="append",
            default=None,
            help=f"the episodes' task text: once for all, or once per trajectory in order (default '{DEFAULT_TASK}')",
        )
        parser.add_argument("--episode", type=int, default=0, help="the episode of a dataset to replay (default 0)")
        add_units_arguments(parser, what="the written")
        add_config_arguments(parser, verb="take the mirror mapping's offsets (simulation.mirror_topic_mappings) from")

    def run(self, args: argparse.Namespace, plugins: PluginHost) -> int:
        if args.episode < 0:
            raise UsageError(f"--episode must be at least 0 (got {args.episode})")
        tasks = args.task or [DEFAULT_TASK]
        if len(tasks) not in (1, len(args.trajectory)):
            raise UsageError(
                f"--task is given {len(tasks)} times for {len(args.trajectory)} trajectories: give it once, or once "
                "per trajectory"
            )
        units = units_from_arguments(args)
        mappings = []
        if args.preset or args.config:
            mappings = mirror_mappings(finalize(load(args, plugins.options())).simulation, plugins)
        elif args.overrides:
            raise UsageError("--set changes the config of --preset or --config; give one of them")
        check_replaceable(args.out, overwrite=args.overwrite, option="--out")
        model = resolve_data_path(args.model)
        sources = [resolve_data_path(item, what="trajectory", folders=True) for item in args.trajectory]
        cameras = [] if args.no_video else (args.camera or [""])
        path = export_trajectories(
            sources,
            model,
            args.out,
            fps=args.fps,
            cameras=cameras,
            size=(args.width, args.height),
            tasks=tasks * len(sources) if len(tasks) == 1 else tasks,
            episode=args.episode,
            plugins=plugins,
            units=units,
            mappings=mappings,
            overwrite=args.overwrite,
        )
        print(f"LeRobot dataset: {path}")
        return 0


# joshua-mirror's option holding the mirror's mappings, found among the run's options by its name.
MAPPINGS_OPTION = "mirror_topic_mappings"


def mirror_mappings(simulation: SimulationConfig, plugins: PluginHost) -> list[TopicMapping]:
    """The mirror's mappings the config sets (`simulation.mirror_topic_mappings`); none without joshua-mirror, whose
    option it is (a config that sets it then fails to load, naming the plugin)."""
    option = plugins.options().find(SimulationConfig.DESCRIPTOR, MAPPINGS_OPTION)
    return list(sub_message(simulation, option).mappings) if option is not None else []


def export_trajectory(
    source: Path,
    model_path: Path,
    out: Path,
    *,
    fps: int,
    cameras: Sequence[str] = ("",),
    size: tuple[int, int] = (DEFAULT_WIDTH, DEFAULT_HEIGHT),
    task: str = DEFAULT_TASK,
    episode: int = 0,
    plugins: PluginHost,
    units: LeRobotUnits = DEFAULT_UNITS,
    mappings: Sequence[TopicMapping] = (),
    overwrite: bool = False,
    option: str = "--out",
) -> Path:
    """`export_trajectories` of the one trajectory `source`."""
    return export_trajectories(
        [source],
        model_path,
        out,
        fps=fps,
        cameras=cameras,
        size=size,
        tasks=[task],
        episode=episode,
        plugins=plugins,
        units=units,
        mappings=mappings,
        overwrite=overwrite,
        option=option,
    )


def export_trajectories(
    sources: Sequence[Path],
    model_path: Path,
    out: Path,
    *,
    fps: int,
    cameras: Sequence[str] = ("",),
    size: tuple[int, int] = (DEFAULT_WIDTH, DEFAULT_HEIGHT),
    tasks: Sequence[str],
    episode: int = 0,
    plugins: PluginHost,
    units: LeRobotUnits = DEFAULT_UNITS,
    mappings: Sequence[TopicMapping] = (),
    overwrite: bool = False,
    option: str = "--out",
) -> Path:
    """Replay each of `sources` (episode `episode` of a dataset) on `model_path` at `fps` and write them to `out` as
    one LeRobot dataset, an episode each with its task of `tasks`; one video per camera of `cameras` ("" = the
    model's first camera; empty: no video) at `size` (w, h). A folder at `out` is replaced only when joshua wrote
    it and `overwrite` is set (`option` names `out` in errors). Values are written in `units`, the mirror's
    `mappings` giving the offsets (robot value = model value - offset)."""
    from joshua_modes import model_joint_ranges
    from joshua_mujoco import compile_model

    model = compile_model(model_path, plugins=plugins)
    ranges = model_joint_ranges(model)
    if mappings:
        units = dataclasses.replace(units, offsets=joint_offsets(model, mappings))
    recorded = [
        _episode(source, model_path, model, ranges, fps, cameras, size, task, episode, plugins)
        for source, task in zip(sources, tasks, strict=True)
    ]
    return write_dataset(out, recorded, fps=fps, joint_ranges=ranges, units=units, overwrite=overwrite, option=option)


def _episode(
    source: Path,
    model_path: Path,
    model: Any,
    ranges: dict[str, tuple[float, float]],
    fps: int,
    cameras: Sequence[str],
    size: tuple[int, int],
    task: str,
    episode: int,
    plugins: PluginHost,
) -> DatasetEpisode:
    """One trajectory resampled at `fps`, its frames rendered while the dataset is written."""
    from joshua_modes import frame_times, iter_offscreen_frames

    trajectory = load_trajectory(source, ranges, episode=episode, plugins=plugins)
    trajectory.require_playable()
    times = frame_times(trajectory.timestamps[0], trajectory.timestamps[-1], fps)
    states, actions = _resampled(trajectory, times)
    width, height = size
    frames = {
        (camera or (model.camera(0).name if model.ncam else "free")): _counted(
            iter_offscreen_frames(
                model_path, source, width, height, camera=camera or None, fps=fps, episode=episode, plugins=plugins
            ),
            len(times),
            camera or "camera",
        )
        for camera in cameras
    }
    return DatasetEpisode(
        joint_names=trajectory.joint_names,
        timestamps=np.arange(len(times)) / fps,
        states=states,
        actions=actions,
        task=task,
        cameras=frames,
    )


def _counted(frames: Iterator[NDArray[np.uint8]], total: int, camera: str) -> Iterator[NDArray[np.uint8]]:
    """`frames` as they are rendered, with a progress bar."""
    with progress_bar(total, description=f"render {camera}", unit="frames") as bar:
        for frame in frames:
            yield frame
            bar.update(1)


def _resampled(trajectory: Trajectory, times: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Positions and targets (positions where a joint has none) interpolated at `times`."""
    positions = np.stack([np.interp(times, trajectory.timestamps, column) for column in trajectory.positions.T], axis=1)
    if trajectory.targets is None:
        return positions, positions.copy()
    targets = positions.copy()
    for j, column in enumerate(trajectory.targets.T):
        known = np.isfinite(column)
        if known.any():
            targets[:, j] = np.interp(times, trajectory.timestamps[known], column[known])
    return positions, targets
