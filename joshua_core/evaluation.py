"""`joshua eval RUN`: roll out a trained policy with the trainer that wrote the run folder.

A run folder (or one checkpoint folder inside it) holds a `config.json` whose `trainer` key names
the trainer plugin that wrote it; the command loads that trainer and calls `Trainer.evaluate`, so
every trainer (sb3, ppo, a third party's) plugs into the same command. The trainer returns each episode's
outcome; the statistics (success rate and mean return with 95 % intervals) are computed here, the same for all,
printed and written as JSON.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from joshua_core.atomic import atomic_write_json, json_safe
from joshua_core.cli import writable_file
from joshua_core.compile_cache import add_no_cache_argument, apply_no_cache
from joshua_core.errors import UsageError
from joshua_core.interfaces import Command
from joshua_core.limits import cli_number
from joshua_core.run_context import RunContext
from joshua_core.runs import add_checkpoint_arguments, read_run_config
from joshua_core.statistics import report_lines, summarize

if TYPE_CHECKING:
    from joshua_core.plugins import PluginHost

# Episodes one evaluation rolls out: far more than an average needs, so a larger count is a typo, not a request.
MAX_EVAL_EPISODES = 100_000


class EvalCommand(Command):
    """`joshua eval RUN`: success rate and mean return of a trained policy with 95 % intervals, as text and JSON,
    and an MP4 of a grid of episodes."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        add_checkpoint_arguments(parser)
        parser.add_argument(
            "--episodes",
            type=cli_number("--episodes", 1, MAX_EVAL_EPISODES, integer=True),
            default=16,
            help="episodes to average over (default 16)",
        )
        parser.add_argument("--seed", type=int, default=0, help="seed of the evaluation environments (default 0)")
        video = parser.add_mutually_exclusive_group()
        video.add_argument("--video", type=Path, help="MP4 to write (default: RUN/eval.mp4)")
        video.add_argument("--no-video", action="store_true", help="do not render a video")
        parser.add_argument(
            "--grid", type=int, default=1, help="episodes tiled in the video, at most --episodes (default 1; 4: 2x2)"
        )
        parser.add_argument("--json", type=Path, help="JSON of the results to write (default: RUN/eval.json)")
        add_no_cache_argument(parser)

    def run(self, args: argparse.Namespace, plugins: PluginHost) -> int:
        apply_no_cache(args)
        if not 1 <= args.grid <= args.episodes:
            raise UsageError(f"--grid must be between 1 and --episodes ({args.episodes}), got {args.grid}")
        run_dir: Path = args.run
        trainer_name = read_run_config(run_dir)["trainer"]
        trainer = plugins.trainer(trainer_name)
        video_path = None if args.no_video else writable_file(args.video or run_dir / "eval.mp4", "--video")
        json_path = writable_file(args.json or run_dir / "eval.json", "--json")
        results = trainer.evaluate(
            run_dir,
            episodes=args.episodes,
            seed=args.seed,
            video_path=video_path,
            context=RunContext(plugins, run_dir),
            trust_checkpoint=args.trust_checkpoint,
            video_grid=args.grid,
        )
        summary = summarize(results)
        print("\n".join(report_lines(summary)))
        per_episode = {"return": results.returns, "length": results.lengths} | dict(results.metrics)
        document = {"run": str(run_dir), "trainer": trainer_name, "seed": args.seed} | summary
        document["per_episode"] = {name: [float(value) for value in values] for name, values in per_episode.items()}
        atomic_write_json(json_path, json_safe(document))
        print(f"results: {json_path}")
        return 0
