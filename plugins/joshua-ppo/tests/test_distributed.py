"""PPO by several processes on jax.distributed, on the CPU: two processes of two virtual devices each
train as one process of four devices does, hold the same parameters, and only process 0 writes or
prints, that they resume together and a signal to one stops both with a checkpoint; processes
started with different configs, a resume by another number of processes, an error of process 0 and
incomplete process settings stop with one line each.

Each process is `distributed_worker.py` in a working directory of its own (as on hosts without a
shared disk), its run folder `runs/` relative to it. A watchdog kills the processes still running
at the deadline, so that a hang fails the test instead of stalling it.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from flax.serialization import msgpack_restore

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.interrupts import StopRequest
from joshua_core.options import parse_dict
from joshua_core.plugins import PluginHost
from joshua_ppo.distributed import ENV_COORDINATOR, ENV_NUM_PROCESSES, ENV_PROCESS_ID, Cluster, join

WORKER = Path(__file__).with_name("distributed_worker.py")
DEADLINE = 240.0  # seconds for one group of processes; measured: 55 s for the first on a loaded 2-core machine
TOLERANCE = 1e-5  # of one process with 4 devices against two with 2; measured: 1.5e-8 (the sums' order)
CONFIG: dict[str, Any] = {  # 8 environments x 5 steps per iteration, 2 iterations
    "task": "slider_reach",
    "num_envs": 8,
    "num_steps": 5,
    "num_epochs": 2,
    "minibatch_size": 20,
    "total_timesteps": 80,
    "seed": 3,
    "checkpoint_dir": "runs",
    "run_name": "slider",
    "hidden_sizes": [16],
    "checkpoint_interval": 80,
    "ppo": {"video_steps": 10, "viewer": "OFF"},
}


@dataclass
class Finished:
    """A worker that exited: its status and what it printed."""

    returncode: int
    stdout: str
    stderr: str


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def start(folder: Path, config: dict[str, Any], *, devices: int, env: dict[str, str] | None = None) -> subprocess.Popen:
    """A worker in `folder` with `devices` virtual CPU devices; its output goes to files there."""
    folder.mkdir(parents=True, exist_ok=True)
    environment = {
        **os.environ,
        "XLA_FLAGS": f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count={devices}",
        # a resume compiles what the first run did: from JAX's cache, shared by the test's workers
        "JAX_COMPILATION_CACHE_DIR": str(folder.parent / "compilation_cache"),
        "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS": "0",
        **(env or {}),
    }
    with (folder / "stdout").open("w") as stdout, (folder / "stderr").open("w") as stderr:
        return subprocess.Popen(
            [sys.executable, str(WORKER), json.dumps(config), str(folder)],
            cwd=folder,
            env=environment,
            stdout=stdout,
            stderr=stderr,
        )


def finish(processes: dict[Path, subprocess.Popen]) -> dict[Path, Finished]:
    """Wait for every worker; at DEADLINE kill those still running and fail."""
    deadline = time.monotonic() + DEADLINE
    try:
        for process in processes.values():
            process.wait(timeout=max(0.0, deadline - time.monotonic()))
    except subprocess.TimeoutExpired:
        for process in processes.values():
            process.kill()
        pytest.fail(f"workers still running after {DEADLINE:.0f} s: {[str(folder) for folder in processes]}")
    return {
        folder: Finished(process.returncode, (folder / "stdout").read_text(), (folder / "stderr").read_text())
        for folder, process in processes.items()
    }


def wait_for_line(process: subprocess.Popen, path: Path, text: str) -> None:
    """Wait until `text` is in the file `path` the running `process` writes (at most DEADLINE)."""
    deadline = time.monotonic() + DEADLINE
    while text not in path.read_text():
        if process.poll() is not None or time.monotonic() > deadline:
            process.kill()
            pytest.fail(f"{path} never said {text!r}: {path.read_text()}")
        time.sleep(0.1)


def two_processes(
    root: Path, config: dict[str, Any], second: dict[str, Any] | None = None
) -> dict[Path, subprocess.Popen]:
    """Process 0 told its place by the config's `ppo.distributed`, process 1 by JOSHUA_* variables."""
    coordinator = f"127.0.0.1:{free_port()}"
    first = {**config, "ppo": {**config["ppo"], "distributed": {"coordinator": coordinator, "num_processes": 2}}}
    variables = {"JOSHUA_COORDINATOR": coordinator, "JOSHUA_NUM_PROCESSES": "2", "JOSHUA_PROCESS_ID": "1"}
    return {
        root / "p0": start(root / "p0", first, devices=2),
        root / "p1": start(root / "p1", second or config, devices=2, env=variables),
    }


def parameters(path: Path) -> list[np.ndarray]:
    restored = msgpack_restore(path.read_bytes())
    params = restored["params"] if "normalizer" in restored else restored
    leaves: list[np.ndarray] = []
    _collect(params, leaves)
    return leaves


def _collect(tree: Any, leaves: list[np.ndarray]) -> None:
    if isinstance(tree, dict):
        for key in sorted(tree):
            _collect(tree[key], leaves)
    else:
        leaves.append(np.asarray(tree))


def largest_difference(a: list[np.ndarray], b: list[np.ndarray]) -> float:
    assert [x.shape for x in a] == [y.shape for y in b]
    return max(float(np.abs(x - y).max()) for x, y in zip(a, b, strict=True))


def one_line_error(finished: Finished) -> str:
    """The one line a worker that stopped with a config error wrote (process 0's stdout may hold Gloo's lines
    about connecting, which the library writes itself)."""
    assert finished.returncode == 2, finished
    assert all(line.startswith("[Gloo] ") for line in finished.stdout.splitlines()), finished.stdout
    lines = finished.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("joshua: error: "), finished.stderr
    return lines[0]


@pytest.mark.slow
def test_two_processes_train_as_one_with_all_their_devices(tmp_path: Path) -> None:
    processes = two_processes(tmp_path, CONFIG)
    processes[tmp_path / "single"] = start(tmp_path / "single", CONFIG, devices=4)
    results = finish(processes)
    for folder, result in results.items():
        assert result.returncode == 0, (folder, result)
    leader, other, single = (tmp_path / name for name in ("p0", "p1", "single"))
    # process 0 writes the run as one process does; process 1 writes and prints nothing
    assert sorted(path.name for path in (leader / "runs").iterdir()) == ["slider", "slider_step_0", "slider_step_80"]
    assert (leader / "runs" / "slider" / "videos" / "step_80.mp4").stat().st_size > 0
    assert "ppo: 8 environments on 4 devices of 2 processes" in results[leader].stdout
    assert not (other / "runs").exists()
    assert results[other].stdout == results[other].stderr == "", results[other]
    config = json.loads((leader / "runs" / "slider" / "config.json").read_text())
    assert config["processes"] == 2 and len(config["devices"]) == 4
    # the same parameters everywhere, as one process with the four devices computes them. The two processes run
    # one program on one replicated array (each update comes out of the same all-reduce), so their copies are
    # the same bits; one process of 4 devices is another program, which sums in another order: TOLERANCE
    ends = {folder: parameters(folder / f"params_{0 if folder != other else 1}.msgpack") for folder in results}
    assert largest_difference(ends[leader], ends[other]) == 0.0
    assert largest_difference(ends[leader], parameters(leader / "runs" / "slider_step_80" / "params.msgpack")) == 0.0
    assert largest_difference(ends[leader], ends[single]) < TOLERANCE
    assert largest_difference(ends[leader], parameters(single / "runs" / "slider_step_0" / "params.msgpack")) > 1e-3

    # resuming: by one process, a one-line error; by two, from where the run was
    longer = {**CONFIG, "total_timesteps": 4000, "resume": True}
    alone = finish({leader: start(leader, longer, devices=4)})[leader]
    assert one_line_error(alone) == (
        "joshua: error: training.resume: run 'slider' was trained by 2 processes, this one has 1; "
        "resume it with as many (the environments are split across them)"
    )
    resuming = two_processes(tmp_path, longer)
    # SIGTERM to process 0 alone, once it trains: both stop after the same iteration, with a checkpoint
    wait_for_line(resuming[leader], leader / "stdout", "compiling the training iteration")
    resuming[leader].send_signal(signal.SIGTERM)
    resumed = finish(resuming)
    assert [result.returncode for result in resumed.values()] == [143, 143], resumed
    assert "ppo: resuming slider from slider_step_80 (80 steps)" in resumed[leader].stdout
    assert "ppo: stopped at 120 steps; checkpoint runs/slider_step_120" in resumed[leader].stdout
    assert resumed[other].stdout == "" and resumed[other].stderr == "joshua: interrupted\n", resumed[other]
    assert (leader / "runs" / "slider_step_120").is_dir() and not (other / "runs").exists()
    assert largest_difference(parameters(leader / "params_0.msgpack"), parameters(other / "params_1.msgpack")) == 0.0


@pytest.mark.slow
def test_processes_started_with_different_configs_stop_with_one_line(tmp_path: Path) -> None:
    results = finish(two_processes(tmp_path, CONFIG, second={**CONFIG, "seed": 4}))
    expected = (
        "joshua: error: the 2 processes were started with different configs (process 1's differs from "
        "process 0's); give every process the same config and --set options"
    )
    assert [one_line_error(result) for result in results.values()] == [expected, expected]
    assert not (tmp_path / "p0" / "runs").exists()


@pytest.mark.parametrize(
    ("distributed", "variables", "message"),
    [
        ({"num_processes": 2}, {}, "training.ppo.distributed.num_processes is 2 but no coordinator (host:port) is set"),
        (
            {"coordinator": "127.0.0.1:1"},
            {"JOSHUA_NUM_PROCESSES": "2", "JOSHUA_PROCESS_ID": "2"},
            "training.ppo.distributed.process_id 2 is not one of the 2 processes (0 to 1)",
        ),
        (
            {},
            {"JOSHUA_COORDINATOR": "127.0.0.1:1"},
            "training.ppo.distributed.num_processes must be at least 2 with a coordinator, got 0",
        ),
        (
            {},
            {"JOSHUA_COORDINATOR": "127.0.0.1:1", "JOSHUA_NUM_PROCESSES": "two"},
            "environment variable JOSHUA_NUM_PROCESSES='two' is not a whole number",
        ),
    ],
)
def test_incomplete_process_settings_are_config_errors(
    distributed: dict[str, Any], variables: dict[str, str], message: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Checked before joining anything: no JAX is initialised."""
    for name in (ENV_COORDINATOR, ENV_NUM_PROCESSES, ENV_PROCESS_ID):
        monkeypatch.delenv(name, raising=False)
    for name, value in variables.items():
        monkeypatch.setenv(name, value)
    config = TrainingConfig()
    parse_dict({"ppo": {"distributed": distributed}}, config, PluginHost.discover().options())
    with pytest.raises(ConfigError) as caught:
        join(config)
    assert str(caught.value) == message


@pytest.mark.slow
def test_an_error_of_process_0_stops_the_others_with_its_message(tmp_path: Path) -> None:
    resume = {**CONFIG, "resume": True}
    results = finish(two_processes(tmp_path, resume))
    missing = "training.resume: there is no run 'slider' in runs to resume"
    assert [one_line_error(result) for result in results.values()] == [
        f"joshua: error: {missing}",
        f"joshua: error: process 0 stopped: {missing}",
    ]


def test_a_signal_landing_after_the_stop_vote_waits_for_the_next_one(monkeypatch: pytest.MonkeyPatch) -> None:
    # process 1 of 2; the other process never got a signal
    cluster, stop = Cluster(process_id=1, num_processes=2), StopRequest()

    def vote_then_signal(_: Cluster, value: int) -> int:
        stop.signum = signal.SIGTERM  # lands just after the values were exchanged: the others were told `value`
        return value

    monkeypatch.setattr(Cluster, "largest", vote_then_signal)
    assert not cluster.agreed_stop(stop)  # so this process trains one more iteration with them
    monkeypatch.setattr(Cluster, "largest", lambda _, value: value)
    assert cluster.agreed_stop(stop)  # and at the next vote all stop
    # the other side: a process the signal did not reach learns it from the vote, to report the same signal
    quiet = StopRequest()
    monkeypatch.setattr(Cluster, "largest", lambda _, value: max(value, signal.SIGTERM))
    assert cluster.agreed_stop(quiet) and quiet.signum == signal.SIGTERM
