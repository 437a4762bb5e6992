"""Benches' child processes, each on its own slice of the machine's devices: GPUs by CUDA_VISIBLE_DEVICES, or on
a CPU host that many virtual CPU devices (XLA's --xla_force_host_platform_device_count), so that a bench of
several GPUs runs end to end on a CPU too.

The parent never starts JAX's backends itself: on a GPU, JAX takes 75 % of every visible GPU's memory when it
starts, which the children need. It asks a short-lived child how many devices there are (`probe`).
"""

from __future__ import annotations

import os
import re
import socket
import subprocess
import sys
from dataclasses import dataclass

from joshua_ppo.distributed import ENV_COORDINATOR, ENV_NUM_PROCESSES, ENV_PROCESS_ID

_CPU_DEVICES = re.compile(r"--xla_force_host_platform_device_count=(\d+)")


@dataclass(frozen=True)
class Machine:
    """The devices a bench may spread its children over: their platform ("gpu" or "cpu") and count."""

    platform: str
    count: int

    def slice_environment(self, first: int, count: int) -> dict[str, str]:
        """The environment variables that give a child the devices first .. first + count - 1 (of a CPU host,
        `count` virtual CPU devices of its own)."""
        if first + count > self.count:
            raise SystemExit(f"devices {first}..{first + count - 1} asked for, {self.count} {self.platform} devices")
        if self.platform == "cpu":
            flags = _CPU_DEVICES.sub("", os.environ.get("XLA_FLAGS", "")).strip()
            return {"JAX_PLATFORMS": "cpu", "XLA_FLAGS": f"{flags} --xla_force_host_platform_device_count={count}"}
        visible = os.environ.get("CUDA_VISIBLE_DEVICES")
        ids = visible.split(",") if visible else [str(index) for index in range(self.count)]
        return {"CUDA_VISIBLE_DEVICES": ",".join(ids[first : first + count])}


def probe() -> Machine:
    """The platform and number of devices JAX sees here, asked of a child process (see the module docstring)."""
    code = "import jax; print(jax.default_backend(), jax.device_count())"
    environment = {**os.environ, "XLA_PYTHON_CLIENT_PREALLOCATE": "false"}
    answer = subprocess.run([sys.executable, "-c", code], env=environment, capture_output=True, text=True, check=True)
    platform, count = answer.stdout.split()[-2:]
    return Machine("cpu" if platform == "cpu" else "gpu", int(count))


def free_port() -> int:
    """A TCP port free on this host now, for jax.distributed's coordinator."""
    with socket.socket() as probe_socket:
        probe_socket.bind(("127.0.0.1", 0))
        return int(probe_socket.getsockname()[1])


def cluster_environment(coordinator: str, count: int, process_id: int) -> dict[str, str]:
    """The variables that place a training process among `count` joined by jax.distributed (joshua_ppo.distributed
    reads them)."""
    return {ENV_COORDINATOR: coordinator, ENV_NUM_PROCESSES: str(count), ENV_PROCESS_ID: str(process_id)}
