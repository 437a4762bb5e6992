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
/ raw physics steps/s); and the same ratio to the physics as the environment steps it, a stricter
reference (`lean_physics_rate`: only the integration state passed between an env step's physics steps).
Anchor: Brax PPO trains Ant for 50 M steps in 2 min 36 s plus 33 s compile; goal: return >= 6000 in
<= 3 min on one H200, training throughput >= 50 % of raw physics, and >= 1.8x on 2 GPUs. `--scaling`
trains on one device, then on all: with the same batch split over them, or with `--weak` the batch
(environments and minibatch) multiplied by the device count, the same work per device.
"""

from __future__ import annotations

import argparse
import dataclasses
import json

import jax
from mjx_time_to_target import (
    IMPLS,
    Snapshot,
    environment,
    evaluate_snapshots,
    impl_assignment,
    lean_physics_rate,
    load_config,
    raw_physics_rate,
    train,
)

from joshua_core.plugins import PluginHost
from joshua_mjx import MjxEnv, Physics
from joshua_ppo.config_settings import PpoSettings
from joshua_ppo.envs import DEFAULT_NUM_ENVS


def evaluate_returns(settings: PpoSettings, env: MjxEnv, snapshots: list[Snapshot]) -> list[dict[str, float]]:
    """Each snapshot's deterministic mean return and episode length (`evaluate_snapshots`)."""
    summaries = evaluate_snapshots(settings, env, snapshots)
    return [{"return": summary["mean_return"], "length": summary["mean_length"]} for summary in summaries]


def scaled(settings: PpoSettings, factor: int) -> PpoSettings:
    """`settings` with `factor` times the minibatch: with `factor` times the environments, the same number of
    gradient steps."""
    optimization = dataclasses.replace(
        settings.optimization, minibatch_size=settings.optimization.minibatch_size * factor
    )
    return dataclasses.replace(settings, optimization=optimization)


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
    parser.add_argument(
        "--impl",
        choices=IMPLS,
        help="MJX's physics: jax or warp (MuJoCo Warp; training.mjx.impl, docs/training-mjx.md); default: the preset's",
    )
    parser.add_argument("--json", help="write the results here")
    args = parser.parse_args()

    plugins = PluginHost.discover()
    config = load_config(args.preset, args.set + impl_assignment(args.impl), args.num_envs, plugins.options())
    settings = PpoSettings.from_config(config)
    Physics.from_training(config).leave_memory_to_warp()  # before jax.devices() starts JAX's backends
    device_sets = [jax.devices()[:1], jax.devices()] if args.scaling else [jax.devices()]
    print(f"devices: {jax.devices()}  preset {args.preset}: {settings.rollout} {settings.optimization}")
    results = []
    num_envs = config.num_envs or DEFAULT_NUM_ENVS
    for devices in device_sets:
        if args.weak:
            settings = scaled(PpoSettings.from_config(config), len(devices))
        env = environment(config, plugins, num_envs * len(devices) if args.weak else num_envs, devices, training=True)
        outcome, snapshots = train(
            settings, env, args.target, args.max_seconds, args.iterations, args.snapshot_interval
        )
        raw, lean = raw_physics_rate(env), lean_physics_rate(env)
        print(
            f"{len(devices)} device(s): raw physics {raw:,.0f} steps/s ({raw / env.task.frame_skip:,.0f} env steps/s); "
            f"stepped as the environment steps it {lean:,.0f} steps/s"
        )
        physics_steps = outcome["train_steps_per_second"] * env.task.frame_skip
        outcome |= {
            "devices": len(devices),
            "raw_physics_steps_per_second": raw,
            "fraction_of_raw_physics": physics_steps / raw,
            "lean_physics_steps_per_second": lean,
            "fraction_of_lean_physics": physics_steps / lean,
        }
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
