"""`joshua eval RUN`: roll out a trained policy with the trainer that wrote the run folder.

A run folder (or one checkpoint folder inside it) holds a `config.json` whose `trainer` key names
the trainer plugin that wrote it; the command loads that trainer and calls `Trainer.evaluate`, so
every trainer (sb3, ppo, a third party's) plugs into the same command. The trainer returns each episode's
outcome; the statistics (success rate and mean return with 95 % intervals) are computed here, the same for all,
printed and written as JSON.

A folder no JOSHUA trainer wrote (its `config.json` has no `trainer` entry, or there is none) goes to the first
registered `PolicyFormat` that accepts it (e.g. joshua-lerobot's `lerobot`: a LeRobot pretrained-policy folder);
each format declares its own options on this command (`add_plugin_arguments`), and the statistics are the same.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from joshua_core.atomic import atomic_write_json, json_safe
from joshua_core.cli import writable_file
from joshua_core.errors import UsageError
from joshua_core.interfaces import Command, EpisodeResults, PolicyFormat
from joshua_core.json_files import read_json_object
from joshua_core.kinds import Kind
from joshua_core.limits import cli_number
from joshua_core.outputs import add_no_cache_argument, apply_no_cache
from joshua_core.run_context import RunContext
from joshua_core.runs import CONFIG_FILE, add_checkpoint_arguments, read_run_config
from joshua_core.statistics import report_lines, summarize

if TYPE_CHECKING:
    from joshua_core.plugins import PluginHost

# Episodes one evaluation rolls out: far more than an average needs, so a larger count is a typo, not a request.
MAX_EVAL_EPISODES = 100_000


class EvalCommand(Command):
    """`joshua eval RUN`: success rate and mean return of a trained policy with 95 % intervals, as text and JSON,
    and an MP4 of a grid of episodes."""

    def __init__(self) -> None:
        self.format_options: dict[str, list[argparse.Action]] = {}  # each policy format's options (refused for others)

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

    def add_plugin_arguments(self, parser: argparse.ArgumentParser, plugins: PluginHost) -> None:
        for name in plugins.names(Kind.POLICY_FORMAT):
            before = len(parser._actions)
            plugins.create(Kind.POLICY_FORMAT, name, PolicyFormat).add_arguments(parser)
            self.format_options[name] = parser._actions[before:]

    def run(self, args: argparse.Namespace, plugins: PluginHost) -> int:
        apply_no_cache(args)
        if not 1 <= args.grid <= args.episodes:
            raise UsageError(f"--grid must be between 1 and --episodes ({args.episodes}), got {args.grid}")
        run_dir: Path = args.run
        policy_format = None if _trainer_run(run_dir) else _policy_format(run_dir, plugins)
        trainer_name = read_run_config(run_dir)["trainer"] if policy_format is None else ""
        self._refuse_other_formats_options(args, policy_format and policy_format[0], run_dir)
        video_path = None if args.no_video else writable_file(args.video or run_dir / "eval.mp4", "--video")
        json_path = writable_file(args.json or run_dir / "eval.json", "--json")
        context = RunContext(plugins, run_dir)
        source: dict[str, str]
        results: EpisodeResults
        if policy_format is None:
            results = plugins.trainer(trainer_name).evaluate(
                run_dir,
                episodes=args.episodes,
                seed=args.seed,
                video_path=video_path,
                context=context,
                trust_checkpoint=args.trust_checkpoint,
                video_grid=args.grid,
            )
            source = {"trainer": trainer_name}
        else:
            name, found = policy_format
            results = found.evaluate(
                run_dir,
                args,
                episodes=args.episodes,
                seed=args.seed,
                video_path=video_path,
                video_grid=args.grid,
                context=context,
            )
            source = {"policy_format": name}
        summary = summarize(results)
        print("\n".join(report_lines(summary)))
        per_episode = {"return": results.returns, "length": results.lengths} | dict(results.metrics)
        document = {"run": str(run_dir)} | source | {"seed": args.seed} | summary
        document["per_episode"] = {name: [float(value) for value in values] for name, values in per_episode.items()}
        atomic_write_json(json_path, json_safe(document))
        print(f"results: {json_path}")
        return 0

    def _refuse_other_formats_options(self, args: argparse.Namespace, used: str | None, run_dir: Path) -> None:
        """A policy format's option given for a folder it does not evaluate would be ignored: a usage error."""
        for name, actions in self.format_options.items():
            given = [action for action in actions if name != used and getattr(args, action.dest) != action.default]
            if given:
                what = "a JOSHUA run folder" if used is None else f"a {used} policy folder"
                raise UsageError(f"{given[0].option_strings[0]} applies to {name} policy folders; {run_dir} is {what}")


def _trainer_run(run_dir: Path) -> bool:
    """Whether `run_dir` looks like a JOSHUA run or checkpoint folder: its config.json names a trainer (or it is
    no folder at all, or its config.json does not read, so that `read_run_config` says what is wrong)."""
    path = run_dir / CONFIG_FILE
    if not run_dir.is_dir():
        return True
    if not path.is_file():
        return False
    try:
        return "trainer" in read_json_object(path, "the run's config")
    except UsageError:
        return True


def _policy_format(run_dir: Path, plugins: PluginHost) -> tuple[str, PolicyFormat] | None:
    """The first registered policy format that accepts the folder `run_dir` (name and instance), or None."""
    for name in plugins.names(Kind.POLICY_FORMAT):
        policy_format = plugins.create(Kind.POLICY_FORMAT, name, PolicyFormat)
        if policy_format.accepts(run_dir):
            return name, policy_format
    return None
