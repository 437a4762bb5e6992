"""`joshua usd eval RUN --physics MUJOCO,PHYSX`: one trained policy rolled out on each physics of the usd
backend, the return and success with 95 % intervals side by side (sim-to-sim).

The run's trainer evaluates it once per physics (`Trainer.evaluate`, as `joshua eval` does) through a
`PhysicsContext`: the run context whose environments are the usd backend's with `training.usd.physics`
replaced, so every trainer that builds its environments through its context compares engines unchanged.
The statistics are the core's (`joshua_core.statistics`), the same `joshua eval` prints.
"""

from __future__ import annotations

import argparse
import importlib.util
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from joshua_core.atomic import atomic_write_json, json_safe
from joshua_core.cli import writable_file
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError, UsageError
from joshua_core.evaluation import MAX_EVAL_EPISODES
from joshua_core.interfaces import EnvKind
from joshua_core.limits import cli_number
from joshua_core.run_context import RunContext
from joshua_core.runs import add_checkpoint_arguments, read_run_config
from joshua_core.statistics import summarize
from joshua_usd.options_pb2 import UsdOptions, usd
from joshua_usd.physx import PHYSX_MISSING

if TYPE_CHECKING:
    from joshua_core.plugins import PluginHost

BACKEND = "usd"  # the backend whose physics option the comparison varies (joshua_usd.plugin registers it)
RESULTS_FILE = "eval_physics.json"  # in the run folder unless --json names another


@dataclass(frozen=True)
class PhysicsContext(RunContext):
    """A run context whose environments come from the usd backend on `physics` (a UsdOptions.Physics value),
    whatever backend and physics the run trained on: the usd backend reads every model the others do."""

    physics: int = UsdOptions.MUJOCO

    def create_envs(self, training: TrainingConfig, kind: EnvKind, **options: Any) -> Any:
        chosen = TrainingConfig()
        chosen.CopyFrom(training)
        chosen.backend = BACKEND
        chosen.Extensions[usd].physics = self.physics
        return super().create_envs(chosen, kind, **options)


def parse_physics(text: str) -> list[int]:
    """`MUJOCO,PHYSX` -> the UsdOptions.Physics values, in order, each once; an unknown name, none at all or
    PHYSX without ovphysx is a one-line UsageError (exit 2) before anything is rolled out."""
    names = list(dict.fromkeys(name.strip().upper() for name in text.split(",") if name.strip()))
    known = UsdOptions.Physics.keys()
    if not names:
        raise UsageError(f"--physics: name one or more of {', '.join(known)} (comma-separated)")
    for name in names:
        if name not in known:
            raise UsageError(f"--physics: unknown physics {name!r}; choose from {', '.join(known)}")
    if "PHYSX" in names and importlib.util.find_spec("ovphysx") is None:
        raise ConfigError(PHYSX_MISSING)
    return [UsdOptions.Physics.Value(name) for name in names]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments of `joshua usd eval`: those of `joshua eval` that apply (no video: PhysX renders nothing)."""
    add_checkpoint_arguments(parser)
    parser.add_argument(
        "--physics",
        default="MUJOCO,PHYSX",
        help="the usd backend's physics to roll the policy out on, comma-separated (default MUJOCO,PHYSX)",
    )
    parser.add_argument(
        "--episodes",
        type=cli_number("--episodes", 1, MAX_EVAL_EPISODES, integer=True),
        default=16,
        help="episodes per physics (default 16)",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the evaluation environments (default 0)")
    parser.add_argument("--json", type=Path, help=f"JSON of the results to write (default: RUN/{RESULTS_FILE})")


def run(args: argparse.Namespace, plugins: PluginHost) -> int:
    """Evaluate the run on each physics, print one table and write the JSON."""
    physics = parse_physics(args.physics)
    run_dir: Path = args.run
    trainer_name = read_run_config(run_dir)["trainer"]
    trainer = plugins.trainer(trainer_name)
    json_path = writable_file(args.json or run_dir / RESULTS_FILE, "--json")
    summaries = {}
    for value in physics:
        name = UsdOptions.Physics.Name(value)
        print(f"{name}:", flush=True)
        results = trainer.evaluate(
            run_dir,
            episodes=args.episodes,
            seed=args.seed,
            video_path=None,
            context=PhysicsContext(plugins, run_dir, physics=value),
            trust_checkpoint=args.trust_checkpoint,
        )
        summaries[name] = summarize(results)
    print("\n".join(table_lines(summaries)))
    document = {"run": str(run_dir), "trainer": trainer_name, "seed": args.seed, "physics": summaries}
    atomic_write_json(json_path, json_safe(document))
    print(f"results: {json_path}")
    return 0


def table_lines(summaries: dict[str, dict[str, Any]]) -> list[str]:
    """One row per physics: episodes, mean length (steps: a fall ends an episode early), mean return with its
    95 % interval and, where the task has a success metric, the success rate with its interval (summaries as
    `joshua_core.statistics.summarize` gives them)."""
    success = any("success_rate" in summary for summary in summaries.values())
    header = ["physics", "episodes", "mean length", "mean return", "95 % interval"]
    header += ["success", "95 % interval"] * success
    rows = [header]
    for name, summary in summaries.items():
        row = [name, str(summary["episodes"]), f"{summary['mean_length']:.1f}", f"{summary['mean_return']:.4g}"]
        row.append(_interval(summary["mean_return_ci95"]))
        if success:
            rate = summary.get("success_rate")
            row += [f"{rate:.3f}", _interval(summary["success_rate_ci95"], 3)] if rate is not None else ["-", "-"]
        rows.append(row)
    widths = [max(len(row[column]) for row in rows) for column in range(len(header))]
    return ["  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=True)).rstrip() for row in rows]


def _interval(bounds: Sequence[float] | None, decimals: int | None = None) -> str:
    if bounds is None:
        return "- (one episode)"
    low, high = bounds
    return f"[{low:.{decimals}f}, {high:.{decimals}f}]" if decimals else f"[{low:.4g}, {high:.4g}]"
