"""Time-to-return of PPO on MJX for Ant, and training throughput against raw MJX physics, in one run; and how
training throughput scales over devices.

    python bench/mjx_train_ant.py                       # tuned preset until mean return 6000 (GPU)
    python bench/mjx_train_ant.py --preset ant_train_mjx --max-seconds 300
    python bench/mjx_train_ant.py --scaling             # throughput on 1, 2, 4... devices: the same batch split
    python bench/mjx_train_ant.py --scaling --weak      # ... each device with the 1-device batch
    python bench/mjx_train_ant.py --scaling --impl warp # the same on MuJoCo Warp
    python bench/mjx_train_ant.py --set training.ppo.reward_scaling=1   # a variant of the preset
    python bench/mjx_train_ant.py --max-seconds 180 --snapshot-interval 10   # denser snapshots
    XLA_FLAGS=--xla_force_host_platform_device_count=4 python bench/mjx_train_ant.py --scaling --smoke   # CPU

Training stops when the training return (episodes that ended in the iteration, with exploration
noise) reaches the target, or at --max-seconds or --iterations. The policy is snapshotted (copied to
the host) every --snapshot-interval iterations and at the end; afterwards every snapshot is evaluated
at once (one compiled rollout, snapshot after snapshot) on the deterministic policy's mean return over
--eval-envs whole 1000-step episodes. The time to the target is the wall time of the first snapshot
that reaches it: the training time, without the evaluations (Brax's PPO leaves them out of its
training walltime too).

Reports: compile seconds (everything before the first iteration: the environments' reset and the
iteration's compilation, which run at once), wall seconds to the target return (compile included,
and without it), every snapshot's deterministic return and episode length, training env steps/s,
the raw physics rate of `vmap(mjx.step)` on the same batch measured in the same run (after
training, so that training compiles from cold), and their ratio (training env steps/s x frame_skip
/ raw physics steps/s); and the same ratio to the physics as the environment steps it, a stricter
reference (`lean_physics_rate`: only the integration state passed between an env step's physics steps).
Anchor: Brax PPO trains Ant for 50 M steps in 2 min 36 s plus 33 s compile; goal: return >= 6000 in
<= 3 min on one H200, training throughput >= 50 % of raw physics.

`--scaling` measures throughput alone, one configuration after another for each count of --devices
(default 1, 2, 4... up to every device): each is bounded by --iterations (default 30) and --max-seconds,
evaluates nothing unless --eval-envs is given, and measures raw physics unless --no-physics. Strong
scaling splits the preset's batch (environments and minibatch) over the devices; `--weak` multiplies it by
their count, the same work per device. After each configuration it prints the summary table so far (env
steps/s, speed-up over the first row, efficiency: speed-up / devices), so a run cut off by a time limit
still shows what it measured. Goals on one host (tuned Ant): weak >= 1.9x on 2 GPUs and >= 3.7x on 4,
strong >= 1.7x on 2 and >= 3.0x on 4.

Both physics implementations spread the environments over a process's devices and average the gradients across
them: a row is one process with that many devices (MuJoCo Warp's Data shares its contact arrays among the
environments it steps together, so each device steps its own share: `joshua_mjx.env.MjxEnv._on_each_device`).
`--independent` measures N devices as N processes started together instead, one device each
(CUDA_VISIBLE_DEVICES; on a CPU host one virtual device each), every one training its own copy on its own share
of the batch, without the gradient average: the row is the sum of their rates, an upper bound on data-parallel
training over those devices, and says how much their steady iterations overlapped in time (below 80 % the sum
overstates it). Rows with and without it show what the gradient average and the one program over several
devices cost.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from mjx_time_to_target import (
    IMPLS,
    SMOKE,
    Snapshot,
    environment,
    evaluate_snapshots,
    impl_assignment,
    lean_physics_rate,
    load_config,
    raw_physics_rate,
    train,
)
from processes import Machine, probe

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.options import options_of
from joshua_core.plugins import PluginHost
from joshua_mjx import MjxEnv, Physics
from joshua_ppo import options_pb2
from joshua_ppo.config_settings import PpoSettings, ppo_settings
from joshua_ppo.envs import DEFAULT_NUM_ENVS

RESULT = "RESULT "  # the line an --independent process reports its outcome on
SCALING_ITERATIONS = 30  # iterations of each --scaling configuration unless --iterations: the median of 29 rates
OVERLAP_WARNING = 0.8  # independent processes whose steady iterations overlapped less: their summed rate overstates


def evaluate_returns(settings: PpoSettings, env: MjxEnv, snapshots: list[Snapshot]) -> list[dict[str, float]]:
    """Each snapshot's deterministic mean return and episode length (`evaluate_snapshots`)."""
    summaries = evaluate_snapshots(settings, env, snapshots)
    return [{"return": summary["mean_return"], "length": summary["mean_length"]} for summary in summaries]


def with_minibatch(settings: PpoSettings, minibatch_size: int) -> PpoSettings:
    """`settings` with another minibatch: with the environments scaled by the same factor, the same number of
    gradient steps."""
    optimization = dataclasses.replace(settings.optimization, minibatch_size=minibatch_size)
    return dataclasses.replace(settings, optimization=optimization)


def batch(config: TrainingConfig, weak: bool, devices: int, shares: int) -> tuple[int, PpoSettings]:
    """(environments, settings) of one of `shares` processes that together train on `devices` devices: weak, the
    preset's batch per device; strong, the preset's batch split over the devices."""
    settings = ppo_settings(options_of(config, options_pb2.ppo), config)
    num_envs, minibatch = config.num_envs or DEFAULT_NUM_ENVS, settings.optimization.minibatch_size
    if weak:
        num_envs, minibatch = num_envs * devices, minibatch * devices
    if num_envs % shares or minibatch % shares:
        raise SystemExit(f"{num_envs} environments and minibatch {minibatch} do not split into {shares} processes")
    return num_envs // shares, with_minibatch(settings, minibatch // shares)


def measure(
    args: argparse.Namespace,
    config: TrainingConfig,
    plugins: PluginHost,
    devices: list[Any],
    num_envs: int,
    settings: PpoSettings,
) -> dict[str, Any]:
    """Train on `devices` as the arguments say; the outcome: throughput, physics rates, evaluated snapshots."""
    env = environment(config, plugins, num_envs, devices, training=True)
    started = time.time()
    outcome, snapshots = train(settings, env, args.target, args.max_seconds, args.iterations, args.snapshot_interval)
    # the steady iterations' span (after the first), wall clock: independent processes' overlap is read from them
    outcome |= {"devices": len(devices), "num_envs": num_envs, "steady_from": started + outcome["compile_seconds"]}
    outcome["steady_until"] = started + outcome["wall_seconds"]
    if args.physics:
        raw = raw_physics_rate(env)
        physics_steps = outcome["train_steps_per_second"] * env.task.frame_skip
        outcome |= {"raw_physics_steps_per_second": raw, "fraction_of_raw_physics": physics_steps / raw}
        if not args.scaling:
            lean = lean_physics_rate(env)
            outcome |= {"lean_physics_steps_per_second": lean, "fraction_of_lean_physics": physics_steps / lean}
        print(
            f"{len(devices)} device(s): raw physics {raw:,.0f} steps/s ({raw / env.task.frame_skip:,.0f} env steps/s)"
        )
    if args.eval_envs > 0 and snapshots:
        eval_envs = -(-args.eval_envs // len(devices)) * len(devices)
        eval_env = environment(config, plugins, eval_envs, devices)
        evaluations = evaluate_returns(settings, eval_env, [snapshot for _, snapshot in snapshots])
        evaluated = [when | result for (when, _), result in zip(snapshots, evaluations, strict=True)]
        reached = next((entry for entry in evaluated if entry["return"] >= args.target), None)
        outcome |= {
            "snapshots": evaluated,
            "deterministic_return": evaluated[-1]["return"],
            "reached_target_at_seconds": reached and reached["wall"],
            "reached_target_without_compile_seconds": reached and reached["wall"] - outcome["compile_seconds"],
            "reached_target_at_steps": reached and reached["step"],
        }
    return outcome


def device_counts(args: argparse.Namespace, available: int) -> list[int]:
    """--devices, else 1, 2, 4... up to `available`, and `available` itself."""
    if args.devices:
        counts = [int(count) for count in args.devices.split(",")]
        if max(counts) > available:
            raise SystemExit(f"--devices {args.devices}: only {available} devices here")
        return counts
    counts = [1]
    while counts[-1] * 2 <= available:
        counts.append(counts[-1] * 2)
    return counts + ([available] if counts[-1] != available else [])


def summary_lines(args: argparse.Namespace, rows: list[dict[str, Any]]) -> list[str]:
    """The scaling table of the configurations measured so far; speed-up against the first row."""
    how = "independent processes, one device each" if args.independent else "one process"
    kind = "weak: the preset's batch per device" if args.weak else "strong: the preset's batch split"
    lines = [
        f"scaling summary ({kind}; MJX-{args.impl.upper()}, {how}):",
        "  devices | env steps/s | speed-up | efficiency | compile s | raw physics steps/s"
        + (" | overlap" if args.independent else ""),
    ]
    for row in rows:
        speedup = row["train_steps_per_second"] / rows[0]["train_steps_per_second"] * rows[0]["devices"]
        raw = row.get("raw_physics_steps_per_second")
        lines.append(
            f"  {row['devices']:7d} | {row['train_steps_per_second']:11,.0f} | {speedup:7.2f}x | "
            f"{speedup / row['devices']:10.0%} | {row['compile_seconds']:9.1f} | "
            + (f"{raw:19,.0f}" if raw else f"{'-':>19}")
            + (f" | {row['overlap']:7.0%}" if args.independent else "")
        )
    return lines


def report(args: argparse.Namespace, results: list[dict[str, Any]]) -> None:
    """Print the summary so far and write --json (after every configuration, so a cut-off run keeps both)."""
    if args.scaling:
        print("\n".join(summary_lines(args, results)), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))


def in_process(args: argparse.Namespace, config: TrainingConfig, plugins: PluginHost) -> None:
    """Every configuration in this process: training, or --scaling over the first N of this process's devices."""
    Physics.from_training(config).leave_memory_to_warp()  # before jax.devices() starts JAX's backends
    import jax

    settings = ppo_settings(options_of(config, options_pb2.ppo), config)
    print(f"devices: {jax.devices()}  preset {args.preset}: {settings.rollout} {settings.optimization}", flush=True)
    counts = device_counts(args, len(jax.devices())) if args.scaling else [len(jax.devices())]
    results = []
    for count in counts:
        num_envs, settings = batch(config, args.weak, count, 1)
        outcome = measure(args, config, plugins, jax.devices()[:count], num_envs, settings)
        print(json.dumps(outcome, indent=1), flush=True)
        results.append(outcome)
        report(args, results)


def worker(args: argparse.Namespace, config: TrainingConfig, plugins: PluginHost) -> None:
    """One of --worker independent processes: train on this process's one device, print the outcome on one line."""
    Physics.from_training(config).leave_memory_to_warp()
    import jax

    num_envs, settings = batch(config, args.weak, args.worker, args.worker)
    outcome = measure(args, config, plugins, jax.devices(), num_envs, settings)
    print(RESULT + json.dumps(outcome), flush=True)


def independent(args: argparse.Namespace, config: TrainingConfig) -> None:
    """Each configuration of N devices as N processes started together, one device each (see the docstring)."""
    machine = probe()
    print(f"{machine.count} {machine.platform} device(s); one process per device", flush=True)
    results = []
    for count in device_counts(args, machine.count):
        outcomes = run_workers(args, machine, count)
        steady = [outcome["steady_until"] - outcome["steady_from"] for outcome in outcomes]
        shared = min(o["steady_until"] for o in outcomes) - max(o["steady_from"] for o in outcomes)
        row = {
            "devices": count,
            "train_steps_per_second": sum(outcome["train_steps_per_second"] for outcome in outcomes),
            "compile_seconds": max(outcome["compile_seconds"] for outcome in outcomes),
            "overlap": max(0.0, shared) / (sum(steady) / len(steady)),
            "processes": outcomes,
        }
        if all("raw_physics_steps_per_second" in outcome for outcome in outcomes):
            row["raw_physics_steps_per_second"] = sum(outcome["raw_physics_steps_per_second"] for outcome in outcomes)
        if row["overlap"] < OVERLAP_WARNING:
            print(f"warning: the {count} processes' steady iterations overlapped {row['overlap']:.0%}", flush=True)
        results.append(row)
        report(args, results)


def run_workers(args: argparse.Namespace, machine: Machine, count: int) -> list[dict[str, Any]]:
    """Start `count` worker processes of this bench, one device each, and wait for them; their outcomes. Process 0
    prints to this one's output as it goes, the others to files shown if they fail."""
    command = [sys.executable, str(Path(__file__).resolve()), *sys.argv[1:], "--worker", str(count)]
    with tempfile.TemporaryDirectory(prefix="mjx-train-ant-") as folder:
        started = []
        for index in range(count):
            variables = {**os.environ, **machine.slice_environment(index, 1)}
            out = Path(folder) / f"stdout_{index}"
            with out.open("w") as stdout:
                started.append((subprocess.Popen(command, env=variables, stdout=stdout), out))
        outcomes = []
        for index, (process, out) in enumerate(started):
            process.wait()
            text = out.read_text()
            lines = [line for line in text.splitlines() if line.startswith(RESULT)]
            if index == 0:
                print("\n".join(line for line in text.splitlines() if not line.startswith(RESULT)), flush=True)
            if process.returncode or not lines:
                raise SystemExit(f"process {index} of {count} failed (exit {process.returncode}):\n{text[-3000:]}")
            outcomes.append(json.loads(lines[-1][len(RESULT) :]))
        return outcomes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", default="ant_train_mjx_tuned")
    parser.add_argument("--target", type=float, default=6000.0)
    parser.add_argument("--max-seconds", type=float, default=420.0)
    parser.add_argument("--num-envs", type=int, help="override the preset's num_envs")
    parser.add_argument(
        "--iterations", type=int, help=f"stop after this many iterations (--scaling: {SCALING_ITERATIONS})"
    )
    parser.add_argument(
        "--eval-envs", type=int, help="episodes of each deterministic evaluation (default 128; --scaling: 0, none)"
    )
    parser.add_argument(
        "--snapshot-interval",
        type=int,
        default=20,
        help="snapshot the policy every this many iterations (0: only at the end; --scaling: 0)",
    )
    parser.add_argument("--scaling", action="store_true", help="throughput on 1, 2, 4... devices (see above)")
    parser.add_argument("--devices", help="with --scaling: the device counts to measure, e.g. 1,2,4")
    parser.add_argument(
        "--weak",
        action="store_true",
        help="with --scaling: on N devices N times the environments and minibatch (the same work per device)",
    )
    parser.add_argument(
        "--independent",
        action="store_true",
        help="with --scaling: N devices as N processes, one device each, training on their own",
    )
    parser.add_argument(
        "--no-physics", dest="physics", action="store_false", help="leave out the raw physics rates (their compiles)"
    )
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE", help="override a preset field")
    parser.add_argument(
        "--impl",
        choices=IMPLS,
        help="MJX's physics: jax or warp (MuJoCo Warp; training.mjx.impl, docs/training-mjx.md); default: the preset's",
    )
    parser.add_argument("--smoke", action="store_true", help="tiny sizes (CPU): 8 envs per device, 3 iterations")
    parser.add_argument("--json", help="write the results here")
    parser.add_argument("--worker", type=int, help=argparse.SUPPRESS)  # one of this many --independent processes
    args = parser.parse_args()
    if args.scaling:
        args.iterations = args.iterations or (3 if args.smoke else SCALING_ITERATIONS)
        args.eval_envs = args.eval_envs or 0
        args.snapshot_interval = 0
    args.eval_envs = 128 if args.eval_envs is None else args.eval_envs
    plugins = PluginHost.discover()
    assignments = (SMOKE if args.smoke else []) + args.set + impl_assignment(args.impl)
    config = load_config(args.preset, assignments, args.num_envs, plugins.options())
    args.impl = Physics.from_training(config).impl  # the summary names it
    args.independent = args.scaling and args.independent
    if args.worker:
        worker(args, config, plugins)
    elif args.independent:
        independent(args, config)
    else:
        in_process(args, config, plugins)


if __name__ == "__main__":
    main()
