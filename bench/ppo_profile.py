"""Where a PPO iteration's device time goes: kernel time grouped by the part of the iteration it serves.

    python bench/ppo_profile.py --preset ant_train_mjx_tuned --out out/profile            # GPU
    python bench/ppo_profile.py --preset so_arm100_pick_place_mjx --out out/profile-pp    # GPU
    python bench/ppo_profile.py --preset ant_train_mjx_tuned --devices 4 --out out/profile-4   # 4 GPUs
    python bench/ppo_profile.py --smoke --out /tmp/profile                                # tiny, on CPU
    XLA_FLAGS=--xla_force_host_platform_device_count=2 \
        python bench/ppo_profile.py --smoke --devices 2 --preset ant_train_mjx_tuned --out /tmp/p2   # 2 on CPU

Compiles a preset's training iteration on --devices devices (default 1; as the trainer does, the environments
split over them, the preset's batch unchanged), runs --warmup iterations,
then traces --iterations more with jax.profiler. Each device operation in the trace names its HLO
instruction; the compiled program's metadata gives that instruction's JAX name stack, where the
iteration's named scopes say what it serves: "rollout" (inside it the environment's step, and in that
"physics": MuJoCo's own step), "update" (forward and backward passes, and the "optimizer"); the collectives
between devices (all-reduces of the gradients, normaliser statistics and metrics) are their own group, by
their opcode. Prints, per device, the share of its busy time per group and how much of the wall time it was
busy (the rest: waiting on the host, on launches and on the other devices), then the busiest instructions;
writes OUT/profile.json and leaves the trace in OUT/trace (Perfetto / TensorBoard).
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import re
import time
from collections import Counter
from pathlib import Path

# XLA's command buffers run many kernels as one trace event named command_buffer_N, which hides the HLO names the
# grouping reads (on an H200 they held 85-97% of the device time); without them each kernel is its own event
os.environ["XLA_FLAGS"] = os.environ.get("XLA_FLAGS", "") + " --xla_gpu_enable_command_buffer="
import jax  # noqa: E402  (after XLA_FLAGS, which jax reads when its backend starts)
from mjx_time_to_target import SMOKE, load_config
from ppo_iteration_rate import compiled_iteration

from joshua_core.atomic import atomic_write_json
from joshua_core.plugins import PluginHost

INSTRUCTION = re.compile(r"^\s*(?:ROOT )?%?([\w.\-]+) = .*?\b([a-z][a-z\-]*)\(.*?op_name=\"([^\"]*)\"", re.M)
CONTAINERS = {"while", "conditional", "call", "async-start", "async-done"}  # their bodies' operations count
COLLECTIVES = ("all-reduce", "all-gather", "reduce-scatter", "collective-permute", "all-to-all")
# the named scopes of mujoco.mjx's step (forward.py): which stage of MuJoCo's pipeline a physics operation serves;
# collisions and the constraint rows are built inside fwd_position
MJX_STAGES = ("fwd_position", "fwd_velocity", "fwd_actuation", "fwd_acceleration", "solve", "euler", "implicit")


def group(op_name: str) -> str:
    """What an operation serves, from its JAX name stack (the iteration's and the environment's named scopes)."""
    parts = op_name.split("/")
    if "rollout" in parts:
        if "physics" in parts:
            stage = next((part for part in parts if part in MJX_STAGES), "other")
            return f"rollout: physics (mjx) {stage}"
        if any(part.startswith("jit(_step)") for part in parts):
            return "rollout: task terms, actions, resets"
        return "rollout: policy, sampling, returns"
    if "update" in parts:
        if "optimizer" in parts:
            return "update: optimizer"
        if any(part.startswith("transpose(") for part in parts):
            return "update: backward passes"
        return "update: forward passes, loss, minibatches"
    return "other: statistics, metrics, keys"


def instruction_groups(hlo_text: str) -> dict[str, str | None]:
    """Instruction name -> group; None for loops and calls, whose time is their bodies' (counted there)."""
    found = INSTRUCTION.findall(hlo_text)
    return {name: None if opcode in CONTAINERS else _group_of(opcode, op_name) for name, opcode, op_name in found}


def _group_of(opcode: str, op_name: str) -> str:
    """A collective's group (with the part it serves), else the group of its name stack."""
    if opcode.startswith(COLLECTIVES):
        return f"collectives: {opcode.removesuffix('-start').removesuffix('-done')} ({group(op_name).split(':')[0]})"
    return group(op_name)


def device_times(trace_dir: Path, module: str) -> dict[str, Counter[str]]:
    """Microseconds per HLO instruction of `module` in the Perfetto trace under `trace_dir`, per device (the
    trace's process, named for the device where the trace names it)."""
    files = sorted(trace_dir.rglob("*.trace.json.gz")) or sorted(trace_dir.rglob("*.json.gz"))
    if not files:
        raise SystemExit(f"no trace was written under {trace_dir}")
    events = json.loads(gzip.decompress(files[-1].read_bytes()))["traceEvents"]
    names = {
        event["pid"]: event.get("args", {}).get("name", str(event["pid"]))
        for event in events
        if event.get("ph") == "M" and event.get("name") == "process_name"
    }
    times: dict[str, Counter[str]] = {}
    for event in events:
        args = event.get("args", {})
        if event.get("ph") == "X" and module in str(args.get("hlo_module", "")) and "hlo_op" in args:
            device = names.get(event.get("pid"), str(event.get("pid")))
            times.setdefault(device, Counter())[args["hlo_op"]] += float(event.get("dur", 0.0))
    return times


def profile(args: argparse.Namespace) -> dict:
    """Compile, warm up, trace; per device, the time per group and per instruction."""
    options = PluginHost.discover().options()
    config = load_config(args.preset, (SMOKE if args.smoke else []) + args.set, args.num_envs, options)
    env, settings, state, compiled = compiled_iteration(config, args.devices)
    groups = instruction_groups(compiled.as_text())
    for _ in range(args.warmup):
        state, _ = jax.block_until_ready(compiled(state))
    trace_dir = args.out / "trace"
    jax.profiler.start_trace(str(trace_dir), create_perfetto_trace=True)
    started = time.perf_counter()
    for _ in range(args.iterations):
        state, _ = jax.block_until_ready(compiled(state))
    wall = time.perf_counter() - started
    jax.profiler.stop_trace()
    traced = device_times(trace_dir, "iteration")
    if not traced:
        raise SystemExit(f"the trace under {trace_dir} has no operations of the iteration (no hlo_op arguments)")
    env_steps = args.iterations * env.num_envs * settings.rollout.num_steps * settings.rollout.unrolls_per_iteration
    return {
        "preset": args.preset,
        "devices": [str(device) for device in env.mesh.devices.flat],
        "num_envs": env.num_envs,
        "iterations": args.iterations,
        "wall_seconds": wall,
        "env_steps_per_second": env_steps / wall,
        "per_device": {device: device_profile(times, groups, wall) for device, times in sorted(traced.items())},
    }


def device_profile(times: Counter[str], groups: dict[str, str | None], wall: float) -> dict:
    """One device's busy share of the wall time, share of its busy time per group, busiest instructions."""
    # an instruction the program text did not name is "unattributed"; loops and calls (None) are left out
    where = {name: groups.get(name, "unattributed") for name in times}
    times = Counter({name: micros for name, micros in times.items() if where[name] is not None})
    per_group: Counter[str] = Counter()
    for name, micros in times.items():
        per_group[where[name]] += micros
    total = sum(per_group.values())
    return {
        "busy_share": total / 1e6 / wall,
        "groups": {name: micros / total for name, micros in per_group.most_common()},
        "busiest": [(name, where[name], micros / total) for name, micros in times.most_common(15)],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", default="so_arm100_pick_place_mjx", help="a preset's name or a .pbtxt file")
    parser.add_argument("--num-envs", type=int, help="override the preset's num_envs")
    parser.add_argument("--devices", type=int, default=1, help="the environments split over this many devices")
    parser.add_argument("--warmup", type=int, default=3, help="iterations before the trace")
    parser.add_argument("--iterations", type=int, default=3, help="iterations traced")
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE", help="override a preset field")
    parser.add_argument("--smoke", action="store_true", help="tiny sizes (CPU)")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    result = profile(args)
    print(
        f"{result['preset']} on {len(result['devices'])} device(s), {result['num_envs']} envs: "
        f"{result['env_steps_per_second']:,.0f} env steps/s while traced"
    )
    for device, found in result["per_device"].items():
        print(f"{device}: busy {found['busy_share']:.0%} of the wall time; of its busy time:")
        for name, share in found["groups"].items():
            print(f"  {share:6.1%}  {name}")
    first = next(iter(result["per_device"].values()))
    print(f"busiest instructions ({next(iter(result['per_device']))}):")
    for name, where, share in first["busiest"]:
        print(f"  {share:6.1%}  {name}  ({where})")
    atomic_write_json(args.out / "profile.json", result)
    print(f"wrote {args.out / 'profile.json'} and the trace under {args.out / 'trace'}")


if __name__ == "__main__":
    main()
