"""Fixtures of the mirror and deploy tests: a ROS environment on loopback, publishers of the wrong type, and the
scenarios on LeRobot arms (lerobot_arm_side.py) run with the real lerobot."""

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
REPO = Path(__file__).resolve().parents[3]
# as setup.sh names them: lerobot 0.4.4 for Python 3.11 in lerobot-site, lerobot 0.6 for 3.12 in lerobot-site-3.12
_VERSION = f"{sys.version_info[0]}.{sys.version_info[1]}"
LEROBOT_SITE = REPO / ".cache" / ("lerobot-site" if _VERSION == "3.11" else f"lerobot-site-{_VERSION}")
NO_TORCHVISION = REPO / "plugins" / "joshua-lerobot" / "tests" / "no_torchvision"  # stands in for torchvision
LEROBOT_SIDE = Path(__file__).with_name("lerobot_arm_side.py")
LEROBOT_SIDE_TIMEOUT_S = 120


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


RunLeRobotSide = Callable[[str], dict[str, Any]]


@pytest.fixture(scope="session")
def lerobot_side(tmp_path_factory: pytest.TempPathFactory) -> RunLeRobotSide:
    """Runs one group of lerobot_arm_side.py's scenarios ("deploy", "mirror") in a process with lerobot 0.4.4 and its
    scservo SDK importable (`./setup.sh --dev` installs them in .cache/lerobot-site); returns its JSON result."""

    def run(group: str) -> dict[str, Any]:
        if not (LEROBOT_SITE / "scservo_sdk").is_dir():
            pytest.fail(f"lerobot with the scservo SDK is not installed in {LEROBOT_SITE}: run ./setup.sh --dev")
        folder = tmp_path_factory.mktemp(f"lerobot_{group}")
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join([str(LEROBOT_SITE), str(NO_TORCHVISION), env.get("PYTHONPATH", "")])
        env |= {"HF_HUB_OFFLINE": "1", "HF_HOME": str(folder / "hf"), "HF_LEROBOT_HOME": str(folder / "hf/lerobot")}
        result = subprocess.run(
            [sys.executable, str(LEROBOT_SIDE), group, str(folder)],
            cwd=LEROBOT_SIDE.parent,
            env=env,
            capture_output=True,
            text=True,
            timeout=LEROBOT_SIDE_TIMEOUT_S,
        )
        assert result.returncode == 0, result.stderr[-4000:]
        return dict(json.loads(result.stdout.strip().splitlines()[-1]))

    return run
