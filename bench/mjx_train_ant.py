"""Time-to-return of PPO on MJX for Ant, and training throughput against raw MJX physics, in one run.

    python bench/mjx_train_ant.py                       # tuned preset until mean return 6000 (GPU)
    python bench/mjx_train_ant.py --preset ant_train_mjx --max-seconds 300
    python bench/mjx_train_ant.py --scaling --iterations 20   # throughput on 1 device vs all devices
    python bench/mjx_train_ant.py --set training.ppo.reward_scaling=1   # a variant of the preset
    python bench/mjx_train_ant.py --eval-interval 50    # the target on whole-episode evaluations

The target return is checked on the training return (episodes that ended in the iteration, with
exploration noise), or with --eval-interval K every K iterations on the deterministic policy's
mean return over --eval-envs whole 1000-step episodes (as Brax checks its periodic evaluations;
evaluation time counts).

Reports: compile seconds, wall seconds to the target return (compile included, and without it),
the final policy's deterministic return over --eval-envs whole episodes, training env steps/s,
the raw physics rate of `vmap(mjx.step)` on the same batch measured in the same run, and their
ratio (training env steps/s x frame_skip / raw physics steps/s). Anchor: Brax PPO trains Ant for
50 M steps in 2 min 36 s plus 33 s compile; goal: return >= 6000 in <= 3 min on one H200,
training throughput >= 50 % of raw physics, and >= 1.8x on 2 GPUs.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable

import jax

from joshua_core.config import apply_override, finalize, load_preset
from joshua_core.plugins import PluginHost
from joshua_mjx.env import MjxEnv
from joshua_mjx.physics import mjx
from joshua_ppo.ppo import IterationReport, TrainingState, train_ppo
from joshua_ppo.rollout import collect, make_rollout, mean_results
from joshua_ppo.trainer import PpoSettings, environment


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


Evaluator = Callable[[TrainingState], float]


def train(
    settings: PpoSettings,
    env: MjxEnv,
    target: float,
    max_seconds: float,
    iterations: int | None,
    evaluate: Evaluator | None = None,
    eval_interval: int = 0,
) -> tuple[dict, TrainingState]:
    """Train until the target (training return, or every `eval_interval` iterations `evaluate`'s), the
    time limit or the iteration limit; returns the outcome and the last state."""
    started = time.perf_counter()
    evaluating = evaluate is not None and eval_interval > 0
    log: list[dict] = []
    evaluations: list[dict] = []
    latest: list[TrainingState] = []

    def on_progress(report: IterationReport, state: TrainingState) -> None:
        latest[:] = [state]
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
        if report.iteration % 10 == 0 or reached:
            print(
                f"  it {report.iteration:4d}  {report.env_steps:>11,} steps  {report.wall_seconds:7.1f} s  "
                f"{report.steps_per_second:>10,.0f} steps/s  return {metrics['mean_return']:8.1f}  "
                f"length {metrics['mean_length']:6.1f}  std {metrics['action_std']:.3f}",
                flush=True,
            )
        if evaluating and report.iteration % eval_interval == 0:
            evaluated = evaluate(state)
            evaluations.append({"step": report.env_steps, "wall": time.perf_counter() - started, "return": evaluated})
            print(f"  eval at {report.env_steps:>11,} steps  {evaluations[-1]['wall']:7.1f} s  return {evaluated:8.1f}")
            reached = evaluated >= target
        elif evaluating:
            reached = False
        if reached or report.wall_seconds > max_seconds or (iterations is not None and report.iteration >= iterations):
            raise TargetReached  # or out of time or iterations

    total = settings.total_timesteps
    try:
        train_ppo(
            env,
            rollout=settings.rollout,
            optimization=settings.optimization,
            returns=settings.returns,
            network=settings.network,
            total_timesteps=total,
            seed=settings.seed,
            on_progress=on_progress,
        )
    except TargetReached:
        pass
    wall = time.perf_counter() - started
    compile_seconds = log[0]["compile"] if log else float("nan")
    steady = [entry["sps"] for entry in log[1:]] or [entry["sps"] for entry in log]
    if evaluating:
        reached = [entry for entry in evaluations if entry["return"] >= target]
    else:
        reached = [entry for entry in log if entry["episodes"] > 0 and entry["return"] >= target]
    return {
        "wall_seconds": wall,
        "compile_seconds": compile_seconds,
        "train_steps_per_second": sorted(steady)[len(steady) // 2],
        "env_steps": log[-1]["step"] if log else 0,
        "final_return": next((e["return"] for e in reversed(log) if e["episodes"] > 0), float("nan")),
        "reached_target_at_seconds": reached[0]["wall"] if reached else None,
        "reached_target_without_compile_seconds": reached[0]["wall"] - compile_seconds if reached else None,
        "reached_target_at_steps": reached[0]["step"] if reached else None,
        "target_on": "evaluation" if evaluating else "training return",
        "evaluations": evaluations,
    }, latest[0]


def make_evaluator(settings: PpoSettings, env: MjxEnv) -> Evaluator:
    """state -> mean return of one whole episode per environment of `env` under the policy's mean (no
    exploration noise), compiled once: the training returns above come from the noisy policy."""
    rollout = make_rollout(env, settings.network, env.task.episode_length)

    def evaluate(state: TrainingState) -> float:
        return mean_results(collect(rollout(state.params, state.normalizer, jax.random.PRNGKey(1))))["mean_return"]

    return evaluate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", default="ant_train_mjx_tuned")
    parser.add_argument("--target", type=float, default=6000.0)
    parser.add_argument("--max-seconds", type=float, default=420.0)
    parser.add_argument("--num-envs", type=int, help="override the preset's num_envs")
    parser.add_argument("--iterations", type=int, help="stop after this many iterations")
    parser.add_argument("--eval-envs", type=int, default=128, help="episodes of each deterministic evaluation")
    parser.add_argument(
        "--eval-interval", type=int, default=0, help="evaluate every this many iterations and check the target on it"
    )
    parser.add_argument("--scaling", action="store_true", help="compare throughput on 1 device and on all devices")
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
    for devices in device_sets:
        env = environment(config, plugins, settings.rollout.num_envs, devices)
        raw = raw_physics_rate(env)
        print(
            f"{len(devices)} device(s): raw physics {raw:,.0f} steps/s ({raw / env.task.frame_skip:,.0f} env steps/s)"
        )
        evaluate = None
        if args.eval_envs > 0:
            eval_envs = -(-args.eval_envs // len(devices)) * len(devices)
            evaluate = make_evaluator(settings, environment(config, plugins, eval_envs, devices))
        outcome, state = train(
            settings, env, args.target, args.max_seconds, args.iterations, evaluate, args.eval_interval
        )
        fraction = outcome["train_steps_per_second"] * env.task.frame_skip / raw
        outcome |= {"devices": len(devices), "raw_physics_steps_per_second": raw, "fraction_of_raw_physics": fraction}
        if evaluate is not None:
            outcome["deterministic_return"] = evaluate(state)
        print(json.dumps(outcome, indent=1))
        results.append(outcome)
    if args.scaling:
        ratio = results[1]["train_steps_per_second"] / results[0]["train_steps_per_second"]
        print(f"throughput {len(jax.devices())} devices / 1 device: {ratio:.2f}x (goal >= 1.8x on 2 GPUs)")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(results, handle, indent=1)


if __name__ == "__main__":
    main()
