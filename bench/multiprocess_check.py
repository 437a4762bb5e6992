"""PPO by several processes on jax.distributed, on one host's devices: 2 processes of 2 devices each train the same
run as 1 process of all 4, and a signal to one of the 2 stops both with a checkpoint.

    python bench/multiprocess_check.py --out out/multiprocess                 # a 4-GPU host: the tuned Ant preset
    XLA_FLAGS=--xla_force_host_platform_device_count=4 python bench/multiprocess_check.py --smoke --out /tmp/mp

What joshua-ppo's tests/test_distributed.py checks on virtual CPU devices, with a real preset on real devices:

1. one process with the 4 devices trains --iterations iterations of the preset (the `ppo` trainer, as `joshua
   train` runs it; videos and the viewer off);
2. two processes, devices 0-1 and 2-3 (CUDA_VISIBLE_DEVICES; on a CPU host 2 virtual devices each), joined by
   jax.distributed on a local coordinator, train the same run: both must end with the same parameters bit for
   bit (one program on one replicated array), and within --tolerance of the single process's (another program;
   joshua-ppo adds the devices' gradients and statistics in device order, so the two can agree to the bit);
3. the two resume that run with a much longer budget, and once process 0's progress line shows an iteration's
   return, process 1 (the one that writes nothing) gets SIGTERM: both must stop after the same iteration with
   exit status 143, process 0 writing a checkpoint and saying so, process 1 saying only that it was
   interrupted, their parameters equal.

Each process runs in a folder of its own under --out (its run folder `runs/` there, its stdout and stderr in
files), with the machine's persistent compilation cache (`joshua_ppo`'s) shared. Prints each step's result,
the largest parameter differences and the wall time of each step; exits 1 if a check fails.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from processes import Machine, cluster_environment, free_port, probe

# joshua-ppo's tests/test_distributed.py (slider_reach): one process of 4 devices against two of 2. Measured here on
# CPU with --smoke Ant (contacts), 5 iterations: 0.0016 while the devices' sums followed the all-reduce's order, 0
# since they are added in device order; the difference is printed either way (--tolerance)
TOLERANCE = 1e-5
RUN = "check"
WAIT_SECONDS = 540.0  # for one step's processes: one device call is 10 minutes
SIGTERM_STATUS = 128 + signal.SIGTERM


def worker(preset: str, assignments: list[str], out: Path) -> int:
    """One training process: the `ppo` trainer on the preset, its run in ./runs; the parameters it ends with
    written to OUT/params_<process>.msgpack. Errors and signals as the `joshua` command reports them."""
    import jax
    from flax import serialization
    from mjx_time_to_target import load_config

    import joshua_ppo.trainer
    from joshua_core.interrupts import reported
    from joshua_core.plugins import PluginHost
    from joshua_core.run_context import RunContext

    host = PluginHost.discover()
    config = load_config(preset, assignments, None, host.options())
    train_ppo = joshua_ppo.trainer.train_ppo

    def keeping(*args: Any, **kwargs: Any) -> Any:
        state, progress = train_ppo(*args, **kwargs)
        params = serialization.to_bytes(jax.device_get(state.params))
        (out / f"params_{jax.process_index()}.msgpack").write_bytes(params)
        return state, progress

    joshua_ppo.trainer.train_ppo = keeping  # the trainer calls it through its module

    def train() -> int:
        joshua_ppo.trainer.PpoTrainer().train(config, RunContext(host, Path(config.checkpoint_dir)))
        return 0

    return reported(train)


def start(
    folder: Path, assignments: list[str], args: argparse.Namespace, variables: dict[str, str]
) -> subprocess.Popen:
    """A worker in `folder` with the environment `variables` added; its output to files there."""
    folder.mkdir(parents=True, exist_ok=True)
    command = [sys.executable, str(Path(__file__).resolve()), "--worker", str(folder), "--preset", args.preset]
    command += [part for assignment in assignments for part in ("--set", assignment)]
    with (folder / "stdout").open("w") as stdout, (folder / "stderr").open("w") as stderr:
        return subprocess.Popen(command, cwd=folder, env={**os.environ, **variables}, stdout=stdout, stderr=stderr)


def wait(processes: dict[Path, subprocess.Popen]) -> dict[Path, int]:
    """Each process's exit status; those still running after WAIT_SECONDS are killed (status None -> -9)."""
    deadline = time.monotonic() + WAIT_SECONDS
    for process in processes.values():
        try:
            process.wait(timeout=max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
    return {folder: process.returncode for folder, process in processes.items()}


def pair(
    root: Path, assignments: list[str], args: argparse.Namespace, machine: Machine
) -> dict[Path, subprocess.Popen]:
    """Two processes of two devices each (devices 0-1 and 2-3), joined on a local coordinator."""
    coordinator = f"127.0.0.1:{free_port()}"
    return {
        root / f"p{index}": start(
            root / f"p{index}",
            assignments,
            args,
            {**machine.slice_environment(2 * index, 2), **cluster_environment(coordinator, 2, index)},
        )
        for index in range(2)
    }


def parameters(path: Path) -> list[np.ndarray]:
    """The leaves of a params msgpack (or of a checkpoint's, which holds the normaliser too), in key order."""
    from flax.serialization import msgpack_restore

    restored = msgpack_restore(path.read_bytes())
    tree = restored["params"] if "normalizer" in restored else restored
    leaves: list[np.ndarray] = []

    def collect(node: Any) -> None:
        if isinstance(node, dict):
            for key in sorted(node):
                collect(node[key])
        else:
            leaves.append(np.asarray(node))

    collect(tree)
    return leaves


def difference(a: Path, b: Path) -> float:
    """The largest absolute difference between two parameter files' leaves."""
    x, y = parameters(a), parameters(b)
    return max(float(np.abs(p - q).max()) for p, q in zip(x, y, strict=True))


class Checks:
    """Prints each check as it is made; remembers whether all passed."""

    def __init__(self) -> None:
        self.failed = 0

    def __call__(self, passed: bool, what: str, detail: Any = "") -> bool:
        """Print the check; whether it passed."""
        self.failed += not passed
        print(f"  {'ok  ' if passed else 'FAIL'} {what}" + (f": {detail}" if detail != "" else ""), flush=True)
        return passed


def tail(folder: Path, name: str, lines: int = 15) -> str:
    return "\n".join((folder / name).read_text().splitlines()[-lines:])


def check(args: argparse.Namespace) -> int:
    machine = probe()
    print(f"{machine.count} {machine.platform} device(s); preset {args.preset}", flush=True)
    if machine.count < 4:
        flag = "XLA_FLAGS=--xla_force_host_platform_device_count=4"
        raise SystemExit(f"the check needs 4 devices (on a CPU host: {flag})")
    from mjx_time_to_target import SMOKE, load_config

    from joshua_core.options import options_of
    from joshua_core.plugins import PluginHost
    from joshua_ppo import options_pb2
    from joshua_ppo.config_settings import ppo_settings

    base = (SMOKE if args.smoke else []) + args.set  # the preset's physics; --set training.mjx.impl=... the other
    config = load_config(args.preset, base, None, PluginHost.discover().options())
    rollout = ppo_settings(options_of(config, options_pb2.ppo), config).rollout
    per_iteration = config.num_envs * rollout.num_steps * rollout.unrolls_per_iteration
    common = base + [
        "training.checkpoint_dir=runs",
        f"training.run_name={RUN}",
        "training.ppo.video_interval=-1",
        "training.ppo.viewer=OFF",
        f"training.checkpoint_interval={per_iteration * args.iterations}",
    ]
    first = common + [f"training.total_timesteps={per_iteration * args.iterations}"]
    checks, root = Checks(), args.out.resolve()

    print(f"1. one process, 4 devices: {args.iterations} iterations of {per_iteration:,} steps", flush=True)
    started = time.perf_counter()
    single = root / "single"
    status = wait({single: start(single, first, args, machine.slice_environment(0, 4))})[single]
    checks(status == 0, f"exit status {status} in {time.perf_counter() - started:.0f} s", tail(single, "stderr", 5))
    print(tail(single, "stdout", 3), flush=True)

    print("2. two processes of 2 devices each: the same run", flush=True)
    started = time.perf_counter()
    statuses = wait(pair(root, first, args, machine))
    leader, other = root / "p0", root / "p1"
    checks(list(statuses.values()) == [0, 0], f"exit statuses {list(statuses.values())}")
    print(f"  ({time.perf_counter() - started:.0f} s)\n" + tail(leader, "stdout", 3), flush=True)
    ends = {folder: folder / f"params_{index}.msgpack" for folder, index in ((single, 0), (leader, 0), (other, 1))}
    if all(path.exists() for path in ends.values()):
        checks(difference(ends[leader], ends[other]) == 0.0, "processes 0 and 1 hold the same parameters")
        gap = difference(ends[leader], ends[single])
        within = f"2 x 2 devices against 1 x 4 within {args.tolerance:g}"
        checks(gap < args.tolerance, within, f"largest difference {gap:.3g}")
        checks(not (other / "runs").exists(), "process 1 wrote no run folder")
    else:
        checks(False, "every process wrote its parameters", [str(path) for path in ends.values() if not path.exists()])
        print(tail(leader, "stderr") + "\n" + tail(other, "stderr"), flush=True)

    print("3. the two resume the run; SIGTERM to process 1 once both train", flush=True)
    started = time.perf_counter()
    longer = common + ["training.resume=true", f"training.total_timesteps={per_iteration * 100_000}"]
    resuming = pair(root, longer, args, machine)
    deadline = time.monotonic() + WAIT_SECONDS
    # process 0's progress line names the return once an iteration has run: both are in the training loop then
    while " return " not in (leader / "stderr").read_text():
        if resuming[leader].poll() is not None or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    resuming[other].send_signal(signal.SIGTERM)
    statuses = wait(resuming)
    if not checks(
        list(statuses.values()) == [SIGTERM_STATUS] * 2, f"exit statuses {list(statuses.values())} (143: SIGTERM)"
    ):
        print(tail(leader, "stderr") + "\n" + tail(other, "stderr"), flush=True)  # what each was doing when it ended
    said = [line for line in (leader / "stdout").read_text().splitlines() if line.startswith("ppo: stopped at")]
    checks(bool(said), "process 0 says where it stopped", said[0] if said else tail(leader, "stderr"))
    last_error = ((other / "stderr").read_text().strip().splitlines() or [""])[-1]
    checks(last_error == "joshua: interrupted", "process 1's last line", repr(last_error))
    if said:
        checkpoint = leader / said[0].split("checkpoint ")[-1]
        checks(checkpoint.is_dir(), f"checkpoint {checkpoint.name} written")
    checks(difference(leader / "params_0.msgpack", other / "params_1.msgpack") == 0.0, "equal parameters at the stop")
    print(f"  ({time.perf_counter() - started:.0f} s)", flush=True)
    print("all checks passed" if not checks.failed else f"{checks.failed} check(s) failed", flush=True)
    return 1 if checks.failed else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", default="ant_train_mjx_tuned")
    parser.add_argument("--iterations", type=int, default=5, help="iterations of steps 1 and 2")
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE", help="override a preset field")
    parser.add_argument("--tolerance", type=float, default=TOLERANCE, help="of the parameters, 2 x 2 against 1 x 4")
    parser.add_argument("--smoke", action="store_true", help="tiny sizes (CPU)")
    parser.add_argument("--out", type=Path, help="folder of the processes' folders")
    parser.add_argument("--worker", type=Path, help=argparse.SUPPRESS)  # a training process writing here
    args = parser.parse_args()
    if args.worker:
        return worker(args.preset, args.set, args.worker)
    if args.out is None:
        parser.error("--out is required")
    return check(args)


if __name__ == "__main__":
    sys.exit(main())
