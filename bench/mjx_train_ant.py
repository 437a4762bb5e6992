"""Time-to-return of PPO on MJX for Ant, and training throughput against raw MJX physics, in one run.

    python bench/mjx_train_ant.py                       # tuned preset until mean return 6000 (GPU)
    python bench/mjx_train_ant.py --preset ant_train_mjx --max-seconds 300
    python bench/mjx_train_ant.py --scaling --iterations 20   # throughput on 1 device vs all devices
    python bench/mjx_train_ant.py --scaling --weak --iterations 20   # ... each device with the 1-device batch
    python bench/mjx_train_ant.py --set training.ppo.reward_scaling=1   # a variant of the preset
    python bench/mjx_train_ant.py --max-seconds 180 --snapshot-interval 10   # denser snapshots

Training stops when the training return (episodes that ended in the iteration, with exploration
noise) reaches the target, or at --max-seconds or --iterations. The policy is snapshotted (copied to
the host) every --snapshot-interval iterations and at the end; afterwards every snapshot is evaluated
at once (one rollout vmapped over the snapshots) on the deterministic policy's mean return over
--eval-envs whole 1000-step episodes. The time to the target is the wall time of the first snapshot
that reaches it: the training time, without the evaluations (Brax's PPO leaves them out of its
training walltime too).

Reports: compile seconds (everything before the first iteration: the environments' reset and the
iteration's compilation, which run at once), wall seconds to the target return (compile included,
and without it), every snapshot's deterministic return and episode length, training env steps/s,
the raw physics rate of `vmap(mjx.step)` on the same batch measured in the same run (after
training, so that training compiles from cold), and their ratio (training env steps/s x frame_skip
/ raw physics steps/s).
Anchor: Brax PPO trains Ant for 50 M steps in 2 min 36 s plus 33 s compile; goal: return >= 6000 in
<= 3 min on one H200, training throughput >= 50 % of raw physics, and >= 1.8x on 2 GPUs. `--scaling`
trains on one device, then on all: with the same batch split over them, or with `--weak` the batch
(environments and minibatch) multiplied by the device count, the same work per device.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from typing import Any

import jax
import numpy as np

from joshua_core.config import apply_override, finalize, load_preset
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.interfaces import EnvKind, EnvSpec
from joshua_core.plugins import PluginHost
from joshua_mjx import MjxBackend, MjxEnv
from joshua_mjx.physics import mjx
from joshua_ppo.config_settings import PpoSettings
from joshua_ppo.envs import DEFAULT_NUM_ENVS
from joshua_ppo.normalizer import RunningStatistics
from joshua_ppo.rollout import collect, make_rollout, mean_results
from joshua_ppo.state import TrainingState
from joshua_ppo.train import IterationReport, train_ppo


class TargetReached(Exception):
    """Stops training once the target return is reached."""


def raw_physics_rate(env: MjxEnv, steps: int = 50) -> float:
    """Physics steps/s of `vmap(mjx.step)` on env's batch, sharded the same way (after compilation)."""
    state = env.reset(jax.random.PRNGKey(0))

    @jax.jit
    def run(data: mjx.Data) -> mjx.Data:
        return jax.lax.fori_loop(0, steps, lambda _, d: jax.vmap(mjx.step, (None, 0))(env.mjx_model, d), data)

    data = jax.block_until_ready(run(state.data))
    best = 0.0
    for _ in range(3):
        started = time.perf_counter()
        data = jax.block_until_ready(run(data))
        best = max(best, steps * env.num_envs / (time.perf_counter() - started))
    return best


Snapshot = tuple[Any, RunningStatistics]  # host copies of a policy's parameters and observation normaliser


def train(
    settings: PpoSettings,
    env: MjxEnv,
    target: float,
    max_seconds: float,
    iterations: int | None,
    snapshot_interval: int = 0,
) -> tuple[dict, list[tuple[dict, Snapshot]]]:
    """Train until the training return reaches the target, the time limit or the iteration limit.

    Returns the outcome and snapshots of the policy every `snapshot_interval` iterations and at the
    end, each with its step and wall seconds, for `evaluate_snapshots`."""
    started = time.perf_counter()
    log: list[dict] = []
    snapshots: list[tuple[dict, Snapshot]] = []

    def on_progress(report: IterationReport, state: TrainingState) -> None:
        metrics = report.metrics
        entry = {
            "step": report.env_steps,
            "wall": report.wall_seconds,
            "sps": report.steps_per_second,
            "return": metrics["mean_return"],
            "episodes": metrics["episodes"],
            "compile": report.compile_seconds,
        }
        log.append(entry)
        reached = metrics["episodes"] > 0 and metrics["mean_return"] >= target
        out_of_budget = report.wall_seconds > max_seconds or report.iteration == iterations
        stopping = reached or out_of_budget or report.env_steps >= report.total_steps
        if report.iteration % 10 == 0 or stopping:
            print(
                f"  it {report.iteration:4d}  {report.env_steps:>11,} steps  {report.wall_seconds:7.1f} s  "
                f"{report.steps_per_second:>10,.0f} steps/s  return {metrics['mean_return']:8.1f}  "
                f"length {metrics['mean_length']:6.1f}  std {metrics['action_std']:.3f}  "
                f"kl {metrics['approx_kl']:.4f}  lr {metrics['learning_rate']:.2e}",
                flush=True,
            )
        if stopping or (snapshot_interval > 0 and report.iteration % snapshot_interval == 0):
            # a host copy: the state's buffers are donated to the next iteration
            when = {"step": report.env_steps, "wall": report.wall_seconds}
            snapshots.append((when, jax.device_get((state.params, state.normalizer))))
        if stopping:
            raise TargetReached  # or out of time, iterations or steps

    try:
        train_ppo(
            env,
            rollout=settings.rollout,
            optimization=settings.optimization,
            returns=settings.returns,
            network=settings.network,
            total_timesteps=settings.total_timesteps,
            seed=settings.seed,
            on_progress=on_progress,
        )
    except TargetReached:
        pass
    compile_seconds = log[0]["compile"] if log else float("nan")
    steady = [entry["sps"] for entry in log[1:]] or [entry["sps"] for entry in log]
    reached = [entry for entry in log if entry["episodes"] > 0 and entry["return"] >= target]
    return {
        "wall_seconds": time.perf_counter() - started,
        "compile_seconds": compile_seconds,
        "train_steps_per_second": sorted(steady)[len(steady) // 2],
        "env_steps": log[-1]["step"] if log else 0,
        "final_return": next((e["return"] for e in reversed(log) if e["episodes"] > 0), float("nan")),
        "training_return_reached_target_at_seconds": reached[0]["wall"] if reached else None,
    }, snapshots


def evaluate_snapshots(settings: PpoSettings, env: MjxEnv, snapshots: list[Snapshot]) -> list[dict[str, float]]:
    """Each snapshot's mean return and episode length over one episode per environment of `env`, under
    the policy's mean (no exploration noise): all snapshots in one rollout, vmapped over them."""
    rollout = make_rollout(env, settings.network, env.task.episode_length)
    params, normalizer = jax.tree.map(lambda *leaves: np.stack(leaves), *snapshots)
    raw = jax.device_get(jax.jit(jax.vmap(rollout, in_axes=(0, 0, None)))(params, normalizer, jax.random.PRNGKey(1)))
    results = [mean_results(collect(jax.tree.map(lambda x, i=i: x[i], raw))) for i in range(len(snapshots))]
    return [{"return": result["mean_return"], "length": result["mean_length"]} for result in results]


def scaled(settings: PpoSettings, factor: int) -> PpoSettings:
    """`settings` with `factor` times the minibatch: with `factor` times the environments, the same number of
    gradient steps."""
    optimization = dataclasses.replace(
        settings.optimization, minibatch_size=settings.optimization.minibatch_size * factor
    )
    return dataclasses.replace(settings, optimization=optimization)


def environment(config: TrainingConfig, plugins: PluginHost, num_envs: int, devices: list[jax.Device]) -> MjxEnv:
    """The mjx backend's environments of the config's task, spread over `devices`."""
    spec = dataclasses.replace(EnvSpec.from_training(config, num_envs=num_envs), devices=devices)
    return MjxBackend().create_envs(spec, EnvKind.JAX, plugins)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", default="ant_train_mjx_tuned")
    parser.add_argument("--target", type=float, default=6000.0)
    parser.add_argument("--max-seconds", type=float, default=420.0)
    parser.add_argument("--num-envs", type=int, help="override the preset's num_envs")
    parser.add_argument("--iterations", type=int, help="stop after this many iterations")
    parser.add_argument("--eval-envs", type=int, default=128, help="episodes of each deterministic evaluation")
    parser.add_argument(
        "--snapshot-interval",
        type=int,
        default=20,
        help="snapshot the policy every this many iterations (0: only at the end)",
    )
    parser.add_argument("--scaling", action="store_true", help="compare throughput on 1 device and on all devices")
    parser.add_argument(
        "--weak",
        action="store_true",
        help="with --scaling: on N devices N times the environments and minibatch (the same work per device)",
    )
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE", help="override a preset field")
    parser.add_argument("--json", help="write the results here")
    args = parser.parse_args()

    loaded = load_preset(args.preset)
    for assignment in args.set:
        apply_override(loaded.message, assignment)
    config = finalize(loaded).training
    if args.num_envs:
        config.num_envs = args.num_envs
    settings = PpoSettings.from_config(config)
    plugins = PluginHost.discover()
    device_sets = [jax.devices()[:1], jax.devices()] if args.scaling else [jax.devices()]
    print(f"devices: {jax.devices()}  preset {args.preset}: {settings.rollout} {settings.optimization}")
    results = []
    num_envs = config.num_envs or DEFAULT_NUM_ENVS
    for devices in device_sets:
        if args.weak:
            settings = scaled(PpoSettings.from_config(config), len(devices))
        env = environment(config, plugins, num_envs * len(devices) if args.weak else num_envs, devices)
        outcome, snapshots = train(
            settings, env, args.target, args.max_seconds, args.iterations, args.snapshot_interval
        )
        raw = raw_physics_rate(env)
        print(
            f"{len(devices)} device(s): raw physics {raw:,.0f} steps/s ({raw / env.task.frame_skip:,.0f} env steps/s)"
        )
        fraction = outcome["train_steps_per_second"] * env.task.frame_skip / raw
        outcome |= {"devices": len(devices), "raw_physics_steps_per_second": raw, "fraction_of_raw_physics": fraction}
        if args.eval_envs > 0 and snapshots:
            eval_envs = -(-args.eval_envs // len(devices)) * len(devices)
            eval_env = environment(config, plugins, eval_envs, devices)
            evaluations = evaluate_snapshots(settings, eval_env, [snapshot for _, snapshot in snapshots])
            evaluated = [when | result for (when, _), result in zip(snapshots, evaluations, strict=True)]
            reached = next((entry for entry in evaluated if entry["return"] >= args.target), None)
            outcome |= {
                "snapshots": evaluated,
                "deterministic_return": evaluated[-1]["return"],
                "reached_target_at_seconds": reached and reached["wall"],
                "reached_target_without_compile_seconds": reached and reached["wall"] - outcome["compile_seconds"],
                "reached_target_at_steps": reached and reached["step"],
            }
        print(json.dumps(outcome, indent=1))
        results.append(outcome)
    if args.scaling:
        ratio = results[1]["train_steps_per_second"] / results[0]["train_steps_per_second"]
        kind = "weak (the same work per device)" if args.weak else "strong (the same batch split)"
        print(f"throughput {len(jax.devices())} devices / 1 device, {kind}: {ratio:.2f}x (goal >= 1.8x on 2 GPUs)")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(results, handle, indent=1)


if __name__ == "__main__":
    main()
