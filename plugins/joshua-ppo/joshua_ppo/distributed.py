"""Several training processes on jax.distributed: joining them, and what they agree on.

Every process runs the same config. `join` connects it to the others (`jax.distributed.initialize`)
before JAX touches a device, so that `jax.devices()` lists every device of every process and the
environments' mesh spans them all: each process steps its slice of the environments and computes
the same parameters, as one process with all the devices would. Process 0 (the leader) alone opens
the run folder and writes logs and checkpoints; `Cluster` carries what the others need from it
(the checkpoint being resumed, its errors, a stop request) through small collectives.
"""

from __future__ import annotations

import hashlib
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

import jax
import numpy as np

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError, JoshuaError
from joshua_core.interrupts import StopRequest
from joshua_ppo import options_pb2

T = TypeVar("T")
OPTIONS = "training.ppo.distributed"
ENV_COORDINATOR, ENV_NUM_PROCESSES, ENV_PROCESS_ID = "JOSHUA_COORDINATOR", "JOSHUA_NUM_PROCESSES", "JOSHUA_PROCESS_ID"
AUTO = "auto"  # coordinator: JAX detects the cluster (SLURM, Open MPI) and every field
STDOUT = 1  # the file descriptor, which libraries write to as well as Python's sys.stdout


class ProcessFailed(JoshuaError):
    """Process 0 failed: this one reports its message and exits with its status."""

    def __init__(self, message: str, exit_code: int) -> None:
        super().__init__(message)
        self.exit_code = exit_code


@dataclass(frozen=True)
class Cluster:
    """This process's place among the processes of one run; one process alone is the default."""

    process_id: int = 0
    num_processes: int = 1

    @property
    def leader(self) -> bool:
        """Process 0: the one that writes the run."""
        return self.process_id == 0

    @property
    def several(self) -> bool:
        return self.num_processes > 1

    def check_same_config(self, config: TrainingConfig) -> None:
        """A ConfigError on every process unless all were started with the same config (`distributed` aside)."""
        if not self.several:
            return
        digests = _allgather(np.frombuffer(_config_digest(config), np.int32))
        differing = [index for index, digest in enumerate(digests) if not np.array_equal(digest, digests[0])]
        if differing:
            raise ConfigError(
                f"the {self.num_processes} processes were started with different configs (process "
                f"{differing[0]}'s differs from process 0's); give every process the same config and --set options"
            )

    def on_leader(self, step: Callable[[], T]) -> T | None:
        """`step()` on process 0 (None elsewhere); if it raises, every process raises: the leader its error,
        the others ProcessFailed with its message and exit status, so that none waits for the others forever."""
        result, error = None, None
        if self.leader:
            try:
                result = step()
            except Exception as caught:  # whatever it is, the others must hear of it
                error = caught
        if self.several:
            report = f"{getattr(error, 'exit_code', 1)} {_describe(error)}" if error is not None else ""
            status, _, message = self.broadcast_bytes(report.encode()).decode().partition(" ")
            if message and not self.leader:
                raise ProcessFailed(f"process 0 stopped: {message}", int(status))
        if error is not None:
            raise error
        return result

    def largest(self, value: int) -> int:
        """The largest of every process's `value` (e.g. the signal of a stop request that reached only one)."""
        return int(_allgather(np.array([value], np.int32)).max()) if self.several else value

    def agreed_stop(self, stop: StopRequest) -> bool:
        """Whether every process stops after this iteration: a signal to any of them stops them all, decided on
        the value they agreed on alone (recorded in `stop` where the signal did not land). A signal that lands
        after the collective is seen by all at the next one; answering from `stop` itself let the signalled
        process stop an iteration before the others, which then waited on it forever."""
        agreed = self.largest(stop.signum or 0)
        if agreed:
            stop.signum = stop.signum or agreed
        return bool(agreed)

    def broadcast_bytes(self, data: bytes | None) -> bytes:
        """Process 0's `data` on every process (the others pass None)."""
        if not self.several:
            return data or b""
        from jax.experimental import multihost_utils

        length = int(multihost_utils.broadcast_one_to_all(np.array([len(data or b"")], np.int32))[0])
        padded = np.zeros(length, np.uint8)
        if self.leader and data:
            padded[:] = np.frombuffer(data, np.uint8)
        return multihost_utils.broadcast_one_to_all(padded).tobytes() if length else b""


def join(config: TrainingConfig) -> Cluster:
    """Connect this process to the others of its run, as `training.ppo.distributed` or the JOSHUA_*
    environment variables describe them (nothing: one process). Call it before anything uses JAX."""
    options = config.Extensions[options_pb2.ppo].distributed
    coordinator = options.coordinator or os.environ.get(ENV_COORDINATOR, "")
    count = options.num_processes or _int_env(ENV_NUM_PROCESSES)
    process_id = options.process_id or _int_env(ENV_PROCESS_ID)
    if jax.distributed.is_initialized():  # the caller joined already (e.g. before calling train_mjx)
        return Cluster(jax.process_index(), jax.process_count())
    if not coordinator:
        if count > 1:
            raise ConfigError(f"{OPTIONS}.num_processes is {count} but no coordinator (host:port) is set")
        return Cluster()
    if coordinator != AUTO and count < 2:
        raise ConfigError(f"{OPTIONS}.num_processes must be at least 2 with a coordinator, got {count}")
    if coordinator != AUTO and not 0 <= process_id < count:
        raise ConfigError(f"{OPTIONS}.process_id {process_id} is not one of the {count} processes (0 to {count - 1})")
    try:
        if coordinator == AUTO:
            jax.distributed.initialize()
        else:
            jax.distributed.initialize(coordinator, count, process_id)
    except (RuntimeError, ValueError) as error:
        message = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ConfigError(f"{OPTIONS}: cannot join the other processes at {coordinator}: {message}") from None
    cluster = Cluster(jax.process_index(), jax.process_count())
    if not cluster.leader:
        _silence_stdout()
    return cluster


def _silence_stdout() -> None:
    """Send this process's standard output (Python's and its libraries', e.g. Gloo's lines about connecting)
    to /dev/null: the processes other than 0 print nothing but errors, on stderr."""
    sys.stdout.flush()
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, STDOUT)
    os.close(devnull)


def _describe(error: Exception) -> str:
    """An error as one line: a JoshuaError's message, or another's type and message."""
    said = str(error).splitlines()[0] if str(error) else ""
    return said if isinstance(error, JoshuaError) and said else f"{type(error).__name__}: {said}"


def _int_env(name: str) -> int:
    value = os.environ.get(name, "")
    try:
        return int(value) if value else 0
    except ValueError:
        raise ConfigError(f"environment variable {name}={value!r} is not a whole number") from None


def _config_digest(config: TrainingConfig) -> bytes:
    """A hash of everything in the config but its `distributed` options (which differ between processes)."""
    copy = TrainingConfig()
    copy.CopyFrom(config)
    copy.Extensions[options_pb2.ppo].ClearField("distributed")
    return hashlib.sha256(copy.SerializeToString(deterministic=True)).digest()


def _allgather(local: np.ndarray) -> np.ndarray:
    """Every process's `local` (same shape everywhere), stacked in process order."""
    from jax.experimental import multihost_utils

    return np.asarray(multihost_utils.process_allgather(local))
