"""Fixtures of joshua-mjx's tests."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable

import pytest


@pytest.fixture
def on_two_cpu_devices() -> Callable[[str], subprocess.CompletedProcess[str]]:
    """Runs a Python script in a process whose JAX has two CPU devices (with the suite's own XLA flags): the
    devices of a run spread over several, which the suite's processes (one device) cannot change once JAX has
    started. Returns the finished process; one that failed fails the test with its stderr."""

    def run(script: str) -> subprocess.CompletedProcess[str]:
        flags = f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count=2"
        env = {**os.environ, "XLA_FLAGS": flags, "JAX_PLATFORMS": "cpu"}
        done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=600)
        assert done.returncode == 0, done.stderr[-3000:]
        return done

    return run
