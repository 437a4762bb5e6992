"""Time to a target on several seeds at once: bench/mjx_time_to_target.py once per seed, one process per GPU.

    python bench/mjx_seeds.py --seeds 0 1 2 --out out/pp -- --preset so_arm100_pick_place_mjx --max-seconds 900
    python bench/mjx_seeds.py --seeds 0 1 --out /tmp/seeds -- --smoke        # tiny, on a CPU, one after the other

Each seed trains in its own process on its own GPU (CUDA_VISIBLE_DEVICES), as many at once as `nvidia-smi -L`
lists GPUs (none: one at a time on the default device), with `--set training.seed=N --out OUT/seed_N` added to
the arguments after `--`; its output goes to OUT/seed_N.log. Afterwards one line per seed (the time to the
target, the best and the last deterministic value), how many seeds reached the target, and every seed's curve in
OUT/curves.png: a learning result should hold on every seed, not on the best of several. Seeds on one host share
its CPUs, which compile. `--report` summarises an OUT that earlier runs (another machine's, say) filled.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

from time_to_target_report import METRICS, plot_curves

BENCH = Path(__file__).with_name("mjx_time_to_target.py")


def gpu_slots() -> list[str | None]:
    """CUDA_VISIBLE_DEVICES values to run on: one per GPU that nvidia-smi lists, else [None] (the default)."""
    if shutil.which("nvidia-smi") is None:
        return [None]
    listed = subprocess.run(["nvidia-smi", "-L"], capture_output=True, text=True, check=False).stdout
    count = sum(line.startswith("GPU ") for line in listed.splitlines())
    return [str(index) for index in range(count)] or [None]


def run_seeds(seeds: list[int], out: Path, arguments: list[str]) -> dict[int, int]:
    """Run the bench for every seed, at most one per GPU at a time; each seed's exit status."""
    out.mkdir(parents=True, exist_ok=True)
    free, waiting, running, status = gpu_slots(), list(seeds), {}, {}
    while waiting or running:
        while waiting and free:
            seed, slot = waiting.pop(0), free.pop(0)
            environment = os.environ | ({"CUDA_VISIBLE_DEVICES": slot} if slot is not None else {})
            command = [sys.executable, str(BENCH), *arguments, "--set", f"training.seed={seed}"]
            command += ["--out", str(out / f"seed_{seed}")]
            with open(out / f"seed_{seed}.log", "wb") as log:
                process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, env=environment)
            running[process.pid] = (seed, slot, process)
            print(f"seed {seed}: started on GPU {slot if slot is not None else '(default)'}", flush=True)
        pid, wait_status = os.wait()  # whichever ends first (reaped here: Popen.wait would not see its status)
        if pid in running:
            seed, slot, process = running.pop(pid)
            process.returncode = status[seed] = os.waitstatus_to_exitcode(wait_status)
            free.append(slot)
            print(f"seed {seed}: finished (exit {status[seed]})", flush=True)
    return status


def summary(seeds: list[int], out: Path, status: dict[int, int]) -> list[str]:
    """One line per seed from its time_to_target.json, then how many reached the target; every seed's curve in
    out/curves.png."""
    lines, reached, curves = [], 0, {}
    for seed in seeds:
        result_file = out / f"seed_{seed}" / "time_to_target.json"
        if status[seed] != 0 or not result_file.is_file():
            lines.append(f"seed {seed}: failed (exit {status[seed]}; see {out / f'seed_{seed}.log'})")
            continue
        result = json.loads(result_file.read_text())
        curves[f"seed {seed}"] = result["snapshots"]
        value_key = METRICS[result["metric"]][1]
        values = [(entry[value_key], entry["wall"]) for entry in result["snapshots"]]
        best, last = max(values), values[-1]
        at = result["reached_target_at_seconds"]
        reached += at is not None
        first = f"{result['metric']} >= {result['target']:g} at {at:.0f} s" if at is not None else "not reached"
        lines.append(
            f"seed {seed}: {first}; best {best[0]:.4g} at {best[1]:.0f} s, last {last[0]:.4g} at {last[1]:.0f} s"
        )
    lines.append(f"{reached} of {len(seeds)} seeds reached the target")
    if curves:
        title = f"{result['preset']}: {len(curves)} seeds, {result['num_envs']} envs"
        (out / "curves.png").write_bytes(plot_curves(curves, result["metric"], result["target"], title))
        lines.append(f"wrote {out / 'curves.png'}")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", required=True)
    parser.add_argument("--out", type=Path, required=True, help="folder for each seed's results and log")
    parser.add_argument("--report", action="store_true", help="summarise OUT's results without running anything")
    parser.add_argument("arguments", nargs=argparse.REMAINDER, help="-- then bench/mjx_time_to_target.py's arguments")
    args = parser.parse_args()
    arguments = args.arguments[1:] if args.arguments[:1] == ["--"] else args.arguments
    status = dict.fromkeys(args.seeds, 0) if args.report else run_seeds(args.seeds, args.out, arguments)
    print("\n".join(summary(args.seeds, args.out, status)))


if __name__ == "__main__":
    main()
