"""`joshua demos`: demonstrations as a LeRobot dataset. A controller is rolled out over randomized episodes
(`EpisodeProducer`: the scripted pick-and-place on the CPU, or on a GPU with MuJoCo Warp through joshua-mjx,
`--physics`), the successful ones are kept and written, one at a time as they come, with camera videos, state and
action in LeRobot's units (the SO-100's degrees and 0-100 gripper by default)."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from joshua_core.cli import add_config_arguments, load
from joshua_core.config import finalize
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.defaults import DEFAULT_OUTPUT_DIR
from joshua_core.errors import JoshuaError, UsageError
from joshua_core.interfaces import Command
from joshua_core.interrupts import HeldSignals, signals_deferred
from joshua_core.limits import MAX_FPS, MIN_FPS, cli_number
from joshua_core.outputs import check_replaceable
from joshua_core.plugins import PluginHost
from joshua_core.progress import progress_bar
from joshua_lerobot.export import add_camera_arguments
from joshua_lerobot.joints import DEFAULT_UNITS, LeRobotUnits, add_units_arguments, units_from_arguments
from joshua_lerobot.rollouts import EpisodeProducer
from joshua_lerobot.video import check_frame_size
from joshua_lerobot.writer import DatasetEpisode, write_dataset

DEFAULT_PRESET = "so_arm100_pick_place_mjx_dr"  # the randomized pick-and-place: its events vary every episode
DEFAULT_EPISODES = 50
ATTEMPTS_PER_EPISODE = 2  # --max-attempts' default, per episode wanted: the script succeeds in most
DEFAULT_NUM_ENVS = 8
DEFAULT_FPS = 25  # every second control step of the 50 Hz pick-and-place
DEFAULT_OUT = Path(DEFAULT_OUTPUT_DIR) / "demos"
MAX_COUNT = 10**7  # episodes or attempts: more is a typo, not a dataset
MAX_NUM_ENVS = 4096  # CPU environments of one batch, each holding an episode's frames
AUTO, CPU, GPU = "auto", "cpu", "gpu"  # --physics


@dataclass(frozen=True)
class DemosReport:
    """What a recording did: episodes kept (successful), attempts rolled out, frames written, wall seconds, and the
    interruption (Ctrl-C) that stopped it early, to be raised once the report is out."""

    kept: int
    attempts: int
    frames: int
    seconds: float
    interrupted: KeyboardInterrupt | None = None

    @property
    def episodes_per_minute(self) -> float:
        return self.kept / self.seconds * 60.0 if self.seconds > 0 else 0.0


class DemosCommand(Command):
    """Rolls the scripted pick-and-place out over randomized episodes and writes the successful ones as a LeRobot
    dataset."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        count = cli_number("--episodes", 1, MAX_COUNT, integer=True)
        parser.add_argument(
            "--episodes", type=count, default=DEFAULT_EPISODES, help=f"successful episodes wanted ({DEFAULT_EPISODES})"
        )
        parser.add_argument(
            "--max-attempts",
            type=cli_number("--max-attempts", 1, MAX_COUNT, integer=True),
            help=f"episodes rolled out at most, failed ones included (default {ATTEMPTS_PER_EPISODE} per one wanted)",
        )
        parser.add_argument(
            "--num-envs",
            type=cli_number("--num-envs", 1, MAX_NUM_ENVS, integer=True),
            default=DEFAULT_NUM_ENVS,
            help=f"environments rolled out at once (default {DEFAULT_NUM_ENVS}); frames of one batch are held",
        )
        add_camera_arguments(parser)
        parser.add_argument(
            "--fps",
            type=cli_number("--fps", MIN_FPS, MAX_FPS, integer=True),
            default=DEFAULT_FPS,
            help=f"dataset frames per second, a divisor of the task's control rate (default {DEFAULT_FPS})",
        )
        parser.add_argument(
            "--physics",
            choices=(AUTO, CPU, GPU),
            default=AUTO,
            help="where the episodes are simulated and rendered: cpu (mujoco.batch, the CPU scene), gpu (MuJoCo Warp "
            "through joshua-mjx, the MJX scene); auto (default): gpu where joshua-mjx, Warp and a GPU are there",
        )
        parser.add_argument("--seed", type=int, help="seed of the episodes' randomization (default: the config's)")
        parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"dataset folder (default {DEFAULT_OUT})")
        parser.add_argument(
            "--overwrite", action="store_true", help="replace the --out folder when joshua wrote it (a dataset)"
        )
        parser.add_argument("--task", help="the episodes' task text (default: the task's own description)")
        add_units_arguments(parser, what="the written")
        add_config_arguments(
            parser, verb=f"take the task, its model and its randomization from (default --preset {DEFAULT_PRESET})"
        )

    def run(self, args: argparse.Namespace, plugins: PluginHost) -> int:
        from joshua_lerobot.scripted_rollouts import SCRIPTED_TASKS

        check_frame_size(args.width, args.height)  # before any rollout, not at the first frame written
        units = units_from_arguments(args)
        check_replaceable(args.out, overwrite=args.overwrite, option="--out")
        if not (args.preset or args.config):
            args.preset = DEFAULT_PRESET
        training = finalize(load(args, plugins.options())).training
        if training.task not in SCRIPTED_TASKS:
            tasks = " or ".join(f"'{task}'" for task in SCRIPTED_TASKS)
            raise UsageError(f"the config's task is '{training.task}'; the scripted controller demonstrates {tasks}")
        producer = make_producer(args, training, plugins)
        try:
            report = record_demonstrations(
                producer,
                args.out,
                episodes=args.episodes,
                max_attempts=args.max_attempts or ATTEMPTS_PER_EPISODE * args.episodes,
                fps=args.fps,
                task=args.task or producer.task_text,
                units=units,
                overwrite=args.overwrite,
            )
        finally:
            producer.close()
        print(f"LeRobot dataset: {args.out} ({report.kept} episodes, {report.frames} frames)")
        print(
            f"{report.kept} of {report.attempts} attempts succeeded in {report.seconds:.1f} s: "
            f"{report.episodes_per_minute:.1f} episodes/minute"
        )
        if report.interrupted is not None:
            print(f"demos: interrupted; the dataset holds the {report.kept} episode(s) kept before it", file=sys.stderr)
            raise report.interrupted
        if report.kept < args.episodes:
            print(f"kept {report.kept} of the {args.episodes} episodes wanted: --max-attempts reached", file=sys.stderr)
        return 0


def make_producer(args: argparse.Namespace, training: TrainingConfig, plugins: PluginHost) -> EpisodeProducer:
    """The scripted pick-and-place producer `--physics` asks for (auto: the GPU's where it runs here)."""
    physics = chosen_physics(args.physics)
    common = {
        "num_envs": args.num_envs,
        "cameras": args.camera or [""],
        "size": (args.width, args.height),
        "fps": args.fps,
        "seed": training.seed if args.seed is None else args.seed,
        "plugins": plugins,
    }
    if physics == GPU:
        from joshua_lerobot.mjx_rollouts import ScriptedMjxProducer

        return ScriptedMjxProducer(training=training, **common)
    from joshua_lerobot.scripted_rollouts import ScriptedMuJoCoProducer

    task_config = training.task_config if training.HasField("task_config") else None
    return ScriptedMuJoCoProducer(task=training.task, task_config=task_config, **common)


def chosen_physics(requested: str) -> str:
    """CPU or GPU for `--physics requested`: auto picks the GPU where joshua-mjx, Warp and a GPU are there; gpu
    without joshua-mjx or Warp is a UsageError, and without a GPU a one-line warning, since Warp then runs on the
    CPU, far slower than --physics cpu."""
    if requested == GPU:
        if missing := gpu_physics_missing():
            raise UsageError(f"--physics gpu needs {missing}: pip install 'joshua-mjx[warp]' (warp-lang, mujoco-warp)")
        if not gpu_present():
            print(
                "joshua: warning: --physics gpu: JAX finds no GPU here, so MuJoCo Warp runs on the CPU, far slower "
                "than --physics cpu",
                file=sys.stderr,
            )
        return GPU
    if requested == AUTO:
        return GPU if not gpu_physics_missing() and gpu_present() else CPU
    return CPU


def gpu_physics_missing() -> str:
    """What the GPU producer needs and this Python lacks: "joshua-mjx", "MuJoCo Warp", or "" (nothing)."""
    try:
        from joshua_mjx import Physics  # noqa: F401  (only whether it is there)
    except ImportError:
        return "joshua-mjx"
    from mujoco.mjx import warp  # joshua-mjx's dependency

    return "" if warp.WARP_INSTALLED else "MuJoCo Warp"


def gpu_present() -> bool:
    """Whether JAX runs on a GPU here. JAX starts its backends to tell, so Warp's share of the GPU's memory is left
    to it first (`Physics.leave_memory_to_warp`)."""
    import jax

    from joshua_mjx import WARP, Physics

    Physics(WARP).leave_memory_to_warp()
    return jax.default_backend() == "gpu"


def record_demonstrations(
    producer: EpisodeProducer,
    out: Path,
    *,
    episodes: int,
    max_attempts: int,
    fps: int,
    task: str,
    units: LeRobotUnits = DEFAULT_UNITS,
    overwrite: bool = False,
) -> DemosReport:
    """Roll `producer` out until `episodes` attempts succeeded or `max_attempts` were made, and write the
    successful ones to `out` as a LeRobot dataset at `fps` with the task text `task`, values in `units`; each is
    encoded as it comes. No success at all is an error and leaves nothing at `out`.

    A signal (Ctrl-C, SIGTERM) stops the rollouts at once, and the episodes kept before it are written as the
    dataset (`DemosReport.interrupted`); one that comes while an episode or the dataset's files are being written
    waits for them, so that what is kept is whole."""
    started = time.perf_counter()
    counts = {"kept": 0, "attempts": 0, "frames": 0}
    stopped: list[KeyboardInterrupt] = []

    def kept(held: HeldSignals) -> Iterator[DatasetEpisode]:
        rollouts = producer.rollouts()
        with progress_bar(episodes, description="demos", unit="episodes") as bar:
            while counts["kept"] < episodes and counts["attempts"] < max_attempts:
                try:
                    with held.interruptible():  # a rollout under way is dropped
                        rollout = next(rollouts)
                except KeyboardInterrupt as interrupt:
                    stopped.append(interrupt)
                    break
                counts["attempts"] += 1
                counts["kept"] += rollout.success
                bar.set_postfix_str(f"{counts['kept']} of {counts['attempts']} attempts succeeded", refresh=False)
                if not rollout.success:
                    continue
                counts["frames"] += rollout.length
                yield DatasetEpisode(  # written with signals held: an episode is in the dataset whole or not at all
                    joint_names=producer.joint_names,
                    timestamps=np.arange(rollout.length) / fps,
                    states=rollout.states,
                    actions=rollout.actions,
                    task=task,
                    cameras=rollout.frames,
                )
                bar.update(1)
        if not counts["kept"]:
            if stopped:
                raise stopped[0]
            raise JoshuaError(f"none of {counts['attempts']} attempts succeeded; no dataset written")

    with signals_deferred() as held:
        write_dataset(out, kept(held), fps=fps, joint_ranges=producer.joint_ranges, units=units, overwrite=overwrite)
        late = held.take()  # came while the last episode or the dataset's files were written: they are whole
    interrupted = stopped[0] if stopped else late
    seconds = time.perf_counter() - started
    return DemosReport(counts["kept"], counts["attempts"], counts["frames"], seconds, interrupted)
