"""The control loop of `joshua deploy`: one policy step per period on fresh encoder values, with the safety holds.

A step runs when its period is due and every joint has a new value (so it sees one consistent state, and
runs at once when that state arrives late). It does not run, and nothing is published, while any joint's
last value is older than `stale_after` (HOLD: the servos keep their last target), while there is no target,
and ever again after an e-stop (latched until the process restarts). At the e-stop, and when the loop ends, one
last message stops the arm in place: each driven joint's target set to its measured position (not when a value
is stale: where the joint is is not known, so its last target stays). The loop sees the arm only through the
link and its transport (`ArmTransport`: ROS 2 topics or a LeRobot robot), so both get the same safety.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from typing import Any

from joshua_core.interrupts import StopRequest, stop_requests
from joshua_mirror.controller import PolicyController
from joshua_mirror.link import RobotLink
from joshua_mirror.mirror import APPLY_LATENCY_SAMPLES, percentiles

STALE_CHECK_PERIOD_S = 0.02
RUNNING, WAITING, HOLD, ESTOP = "RUNNING", "WAITING", "HOLD", "E-STOP"


@dataclass
class LoopStats:
    """What the loop did, for the status line and the report."""

    steps: int = 0
    published: int = 0  # target messages: one per driven joint and step, and those of the stop in place
    steps_at_last_status: int = 0
    hold_episodes: int = 0
    hold_seconds: float = 0.0
    estop_after_s: float | None = None  # seconds from the start to the e-stop
    input_to_publish_us: list[float] = field(default_factory=list)  # newest encoder value's arrival -> published
    compute_us: list[float] = field(default_factory=list)  # values taken -> targets published

    def add_latency(self, arrived_ns: int, taken_ns: int, published_ns: int) -> None:
        for samples, since in ((self.input_to_publish_us, arrived_ns), (self.compute_us, taken_ns)):
            if len(samples) >= APPLY_LATENCY_SAMPLES:
                del samples[: APPLY_LATENCY_SAMPLES // 2]
            samples.append((published_ns - since) / 1e3)

    def report(self) -> dict[str, Any]:
        return {
            "steps": self.steps,
            "published_messages": self.published,
            "holds": {"episodes": self.hold_episodes, "seconds": self.hold_seconds},
            "estop": {"latched": self.estop_after_s is not None, "after_s": self.estop_after_s},
            "latency_us": {
                "input_to_publish": percentiles(self.input_to_publish_us),
                "compute": percentiles(self.compute_us),
            },
        }


class DeployLoop:
    """Runs the controller on the link's values at `rate`, until the duration, Ctrl-C/SIGTERM or a transport
    problem (a wrong message type, a lost port)."""

    def __init__(
        self,
        link: RobotLink,
        controller: PolicyController,
        *,
        rate: float,
        stale_after: float,
        status_period: float,
        fixed_target: Any,
    ) -> None:
        self.link = link
        self.controller = controller
        self.transport = link.transport
        self.period = 1.0 / rate
        self.stale_after = stale_after
        self.status_period = status_period
        self.fixed_target = fixed_target  # --target, until a message on --target-topic replaces it
        self.stats = LoopStats()
        self.state = WAITING
        self.reason = "starting"
        self.state_since = 0.0
        self.wall_seconds = 0.0
        self.stopped_in_place = False  # the stop-in-place targets went out (at the e-stop or the end)

    def run(self, duration: float) -> str:
        """Loop until `duration` seconds (0: no limit); return what stopped it. The first Ctrl-C or SIGTERM ends
        the loop between steps, so that a step's targets go out whole and counted (raised in the middle of one,
        it sent the robot 2 of 6 targets that the report did not count); a second one interrupts at once."""
        start = time.monotonic()
        try:
            with stop_requests() as request:
                return self._loop(start, start + duration if duration > 0 else float("inf"), request)
        except KeyboardInterrupt as interrupt:
            return str(interrupt) or "SIGINT"  # Terminated's text is SIGTERM
        finally:
            self.wall_seconds = time.monotonic() - start
            self._leave_state(time.monotonic())
            self.stop_in_place()

    def _loop(self, start: float, deadline: float, request: StopRequest) -> str:
        self.start = start
        next_due, next_status = start, start + self.status_period
        if problem := self._problems():
            return problem
        while True:
            if request.requested:
                return str(request.interrupted())  # the signal's name
            now = time.monotonic()
            if now >= deadline:
                return "duration"
            if now >= next_status:
                next_status = now + self.status_period
                if problem := self._problems():
                    return problem
                _say(self._status_line(now))
            self._update_state(now)
            if self.state == RUNNING and now >= next_due and self._step():
                next_due = max(next_due + self.period, now)  # late: no burst of catch-up steps
            wake = min(deadline, next_status, now + STALE_CHECK_PERIOD_S)
            if self.state == RUNNING and next_due > now:
                wake = min(wake, next_due)
            self.link.wait(wake - time.monotonic())

    def _step(self) -> bool:
        """One policy step on the newest values, if every joint has a new one; True when targets went out."""
        taken = self.link.take()
        if taken is None:
            return False
        taken_ns = time.perf_counter_ns()
        positions, velocities, arrived_ns = taken
        self._publish(self.controller.step(positions, velocities, self.target()))
        self.stats.add_latency(arrived_ns, taken_ns, time.perf_counter_ns())
        self.stats.steps += 1
        return True

    def target(self) -> Any:
        return self.link.target if self.link.target is not None else self.fixed_target

    def _update_state(self, now: float) -> None:
        """RUNNING, or why not (E-STOP latched, HOLD on stale values, WAITING for first values, a target or a
        subscriber on every command topic)."""
        link = self.link
        ages = link.ages(time.perf_counter_ns())
        names = [joint.joint for joint in link.joints]
        if link.estop_at is not None:
            state, reason = ESTOP, "latched: no targets are published until restart"
        elif (ages == float("inf")).any():
            silent = [name for name, age in zip(names, ages, strict=True) if age == float("inf")]
            state, reason = WAITING, "no value yet from " + ", ".join(silent)
        elif (ages > self.stale_after).any():
            stale = [f"{n} ({a:.2f} s)" for n, a in zip(names, ages, strict=True) if a > self.stale_after]
            state, reason = HOLD, f"no value for {self.stale_after:g} s from " + ", ".join(stale)
        elif self.target() is None:
            state, reason = WAITING, "no target yet"
        elif unheard := link.unheard():  # the first targets would be lost before the robot's side is matched
            state, reason = WAITING, "no subscriber yet on " + ", ".join(unheard)
        else:
            state, reason = RUNNING, ""
        if state != self.state:
            self._leave_state(now)
            self.state, self.state_since = state, now
            if state == HOLD:
                self.stats.hold_episodes += 1
            if state == ESTOP:
                self.stats.estop_after_s = (link.estop_at or now) - self.start
                self.stop_in_place()
            if state == RUNNING:
                self.controller.restart()  # velocities and the speed limit start from the measured state
            _say(f"joshua: deploy: {state}" + (f": {reason}" if reason else f" at {1 / self.period:g} Hz"))
        self.reason = reason

    def stop_in_place(self) -> None:
        """Send each driven joint its measured position as target, once per stop, if every value is recent."""
        if self.stopped_in_place or not self.stats.published:
            return  # already stopped, or nothing was ever sent: the robot is where it was
        ages = self.link.ages(time.perf_counter_ns())
        if (ages > self.stale_after).any():
            _say("joshua: deploy: encoder values are stale: the last targets stay")
            return
        self._publish(self.controller.hold_targets(self.link.positions()))
        self.stopped_in_place = True

    def _publish(self, targets: Any) -> None:
        self.link.publish(targets)
        self.stats.published += len(targets)

    def _leave_state(self, now: float) -> None:
        if self.state == HOLD:
            self.stats.hold_seconds += now - self.state_since

    def _problems(self) -> str | None:
        """Say the transport's new problems; what stops the run, if anything does."""
        for line in self.transport.poll():
            _say(f"joshua: deploy: {line}")
        return self.transport.broken()

    def _status_line(self, now: float) -> str:
        stats = self.stats
        rate = (stats.steps - stats.steps_at_last_status) / self.status_period
        stats.steps_at_last_status = stats.steps
        latency = percentiles(stats.input_to_publish_us[-int(10 / self.period) :])
        timing = f" | input->target p50 {latency['p50'] / 1e3:.2f} ms" if latency["samples"] else ""
        limited = sum(entry.limited for entry in self.controller.actuated)
        slowed = sum(entry.slowed for entry in self.controller.actuated)
        state = self.state + (f" {self.reason}" if self.reason else "")
        return (
            f"[deploy {now - self.start:6.1f} s] {state} | {rate:.0f} steps/s{timing} | "
            f"limited {limited} slowed {slowed}{self.transport.status()}"
        )


def _say(line: str) -> None:
    print(line, file=sys.stderr, flush=True)
