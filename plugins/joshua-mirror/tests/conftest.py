"""Fixtures of the mirror and deploy tests: a ROS environment on loopback, and publishers of the wrong type."""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from joshua_mirror.ros import local_only_environment

PUBLISHER = Path(__file__).with_name("publisher.py")


def _domain_id() -> int:
    """This process's ROS domain, 1-100: random per test run, and apart for each pytest-xdist worker of a run
    (xdist gives all workers of a run one PYTEST_XDIST_TESTRUNUID and each its own PYTEST_XDIST_WORKER, gwN)."""
    run = os.environ.get("PYTEST_XDIST_TESTRUNUID")
    first = int(run, 16) if run else random.randrange(100)
    worker = int(os.environ.get("PYTEST_XDIST_WORKER", "gw0").removeprefix("gw"))
    return 1 + (first + worker) % 100


DOMAIN_ID = _domain_id()


@pytest.fixture
def ros_env(tmp_path: Path) -> dict[str, str]:
    """DDS traffic on this machine only, in this run's domain; rcl logs into the test's folder."""
    return {**local_only_environment(DOMAIN_ID), "ROS_LOG_DIR": str(tmp_path / "ros_log")}


HoldPublishers = Callable[[dict[str, str], list[dict[str, Any]]], subprocess.Popen[str]]


@pytest.fixture
def hold_publishers() -> Iterator[HoldPublishers]:
    """Start a publisher process (tests/publisher.py) that keeps `messages`' publishers in the graph; returns once
    they exist. Each is stopped (SIGINT) when the test ends."""
    holders: list[subprocess.Popen[str]] = []

    def hold(env: dict[str, str], messages: list[dict[str, Any]]) -> subprocess.Popen[str]:
        plan = json.dumps({"hold": True, "messages": messages})
        holder = subprocess.Popen([sys.executable, str(PUBLISHER), plan], env=env, stdout=subprocess.PIPE, text=True)
        holders.append(holder)
        assert holder.stdout is not None and holder.stdout.readline() == "ready\n"
        return holder

    yield hold
    for holder in holders:
        holder.send_signal(signal.SIGINT)
        holder.communicate(timeout=30)
