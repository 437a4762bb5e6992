"""The deploy loop stops on Ctrl-C between steps: a signal that arrives while a step's targets go out lets them
all go out, counted. Raised in the middle of a step, it once sent the robot 2 of 6 targets that the report did
not count (test_deploy.py saw 50 commands for 48 published). Link and controller here are stand-ins that
send the signal from inside the publishing, where no real robot could time it."""

from __future__ import annotations

import os
import signal
import time
from typing import Any

import numpy as np

from joshua_mirror.deploy_loop import DeployLoop

JOINTS = 6


class SignallingLink:
    """Fresh values for every step; its publish sends SIGINT to this process after the second of six targets."""

    def __init__(self) -> None:
        self.joints = [type("Joint", (), {"joint": f"joint_{i}"})() for i in range(JOINTS)]
        self.transport = Quiet()
        self.target: Any = np.zeros(3)
        self.estop_at: float | None = None
        self.sent = 0
        self.steps = 0

    def ages(self, now_ns: int) -> Any:
        return np.zeros(JOINTS)

    def unheard(self) -> list[str]:
        return []

    def take(self) -> tuple[Any, Any, int]:
        return np.zeros(JOINTS), np.zeros(JOINTS), time.perf_counter_ns()

    def positions(self) -> Any:
        return np.zeros(JOINTS)

    def publish(self, targets: Any) -> None:
        self.steps += 1
        for index in range(len(targets)):
            if self.steps == 3 and index == 2:
                os.kill(os.getpid(), signal.SIGINT)  # the handler runs here, between two targets
            self.sent += 1

    def wait(self, timeout: float) -> None:
        time.sleep(max(0.0, min(timeout, 0.001)))


class Holding:
    """A controller that asks for the positions it is given."""

    actuated: list[Any] = []

    def step(self, positions: Any, velocities: Any, target: Any) -> Any:
        return np.zeros(JOINTS)

    def hold_targets(self, positions: Any) -> Any:
        return np.zeros(JOINTS)

    def restart(self) -> None:
        pass


class Quiet:
    """A transport with nothing to say."""

    def poll(self) -> list[str]:
        return []

    def broken(self) -> None:
        return None


def test_a_ctrl_c_while_targets_go_out_stops_after_the_step_with_every_target_counted() -> None:
    link = SignallingLink()
    loop = DeployLoop(link, Holding(), rate=1000.0, stale_after=1.0, status_period=10.0, fixed_target=np.zeros(3))  # type: ignore[arg-type]
    stopped_by = loop.run(duration=30.0)
    assert stopped_by == "SIGINT"
    assert loop.stats.steps == 3  # the step under way finished; no step after it
    assert link.sent == loop.stats.published == 6 * 3 + 6  # its six targets and the stop in place, all counted
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # Ctrl-C is Python's own again
