"""`joshua eval RUN`: roll out a trained policy with the trainer that wrote the run folder.

A run folder (or one checkpoint folder inside it) holds a `config.json` whose `trainer` key names
the trainer plugin that wrote it; the command loads that trainer and calls `Trainer.evaluate`, so
every trainer (sb3, ppo, a third party's) plugs into the same command.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from joshua_core.cli import writable_file
from joshua_core.errors import UsageError
from joshua_core.interfaces import Command, RunContext
from joshua_core.runs import read_run_config

if TYPE_CHECKING:
    from joshua_core.plugins import PluginHost


class EvalCommand(Command):
    """`joshua eval RUN`: mean return and task metrics of a trained policy, and an MP4 of one episode."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("run", type=Path, help="run folder (its last checkpoint) or one checkpoint folder")
        parser.add_argument("--episodes", type=int, default=16, help="episodes to average over (default 16)")
        parser.add_argument("--seed", type=int, default=0, help="seed of the evaluation environments (default 0)")
        video = parser.add_mutually_exclusive_group()
        video.add_argument("--video", type=Path, help="MP4 to write (default: RUN/eval.mp4)")
        video.add_argument("--no-video", action="store_true", help="do not render a video")
        parser.add_argument(
            "--trust-checkpoint",
            action="store_true",
            help="load a run folder written by someone else (its files may run code when loaded: trust it first)",
        )

    def run(self, args: argparse.Namespace, plugins: PluginHost) -> int:
        if args.episodes < 1:
            raise UsageError(f"--episodes must be at least 1, got {args.episodes}")
        run_dir: Path = args.run
        trainer_name = read_run_config(run_dir)["trainer"]
        trainer = plugins.trainer(trainer_name)
        video_path = None if args.no_video else writable_file(args.video or run_dir / "eval.mp4", "--video")
        results = trainer.evaluate(
            run_dir,
            episodes=args.episodes,
            seed=args.seed,
            video_path=video_path,
            context=RunContext(plugins, run_dir),
            trust_checkpoint=args.trust_checkpoint,
        )
        for name, value in results.items():
            print(f"{name}: {value:.6g}")
        return 0
