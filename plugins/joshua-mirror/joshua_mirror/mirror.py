"""`Mirror`: writes checked encoder values into a MuJoCo simulation and keeps the per-joint statistics.

`receive` runs on the transport's thread (ROS 2's or a LeRobot arm's reader) for every message or reading, the
`ArmEvents` of `joshua_mirror.transport`; the main thread steps physics, renders
and prints status. One lock guards `MjData`; `receive` holds it only to write qpos/ctrl and run
mj_forward (tens of microseconds), and the main thread holds it for one physics step at a time.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from joshua_mirror.joints import MirroredJoint
from joshua_mirror.loss import TopicLoss
from joshua_mirror.options_pb2 import MirrorOptions

APPLY_LATENCY_SAMPLES = 100_000  # kept for the report's percentiles; older ones are dropped


@dataclass
class JointStats:
    """What happened to one joint's messages."""

    received: int = 0
    accepted: int = 0
    rejected_non_finite: int = 0
    rejected_out_of_range: int = 0
    clamped: int = 0
    last_value: float | None = None  # the last accepted encoder value
    last_rejected_value: float | None = None
    last_accepted_at: float | None = None  # monotonic seconds
    stale: bool = False
    stale_episodes: int = 0
    received_at_last_status: int = 0
    # sim - real at each message when tracking through actuators, as running sums: a twin runs for hours
    error_samples: int = 0
    error_sum_squares: float = 0.0
    error_max_abs: float = 0.0

    @property
    def rejected(self) -> int:
        return self.rejected_non_finite + self.rejected_out_of_range

    def add_error(self, error: float) -> None:
        self.error_samples += 1
        self.error_sum_squares += error * error
        self.error_max_abs = max(self.error_max_abs, abs(error))

    def error_summary(self) -> dict[str, Any]:
        """RMS and largest absolute sim-vs-real error (radians or metres) over the messages of this joint."""
        if not self.error_samples:
            return {"samples": 0, "rms": None, "max_abs": None}
        return {
            "samples": self.error_samples,
            "rms": math.sqrt(self.error_sum_squares / self.error_samples),
            "max_abs": self.error_max_abs,
        }


class Mirror:
    """The mirrored simulation: engine state, the mapped joints and what their messages did."""

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        joints: list[MirroredJoint],
        options: MirrorOptions,
        *,
        stale_timeout: float,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.model = model
        self.data = data
        self.joints = joints
        self.kinematic = options.apply in (MirrorOptions.KINEMATIC, MirrorOptions.KINEMATIC_AND_ACTUATOR)
        self.actuated = options.apply in (MirrorOptions.ACTUATOR, MirrorOptions.KINEMATIC_AND_ACTUATOR)
        self.range_margin = options.range_margin
        self.stale_timeout = stale_timeout
        self.clock = clock
        self.lock = threading.Lock()
        self.stats = [JointStats() for _ in joints]
        self.unknown_names: dict[str, int] = {}  # JointState names (or Float64 topics) nobody mapped
        self.malformed = 0  # JointState messages whose position list is shorter than their name list
        self.loss: dict[str, TopicLoss] = {}  # per subscribed topic: messages lost before the mirror read them
        self.lost_at_last_warning = 0
        self.apply_latency_us: list[float] = []  # message callback entered -> state updated
        self.started_at = clock()
        self.on_applied: Callable[[int, float], None] | None = None  # (joint index, value) after each update

    def receive(self, updates: Iterable[tuple[int, float]], entered_ns: int) -> None:
        """Check each (joint index, encoder value) and write the good ones; `entered_ns` is when the callback began."""
        now = self.clock()
        accepted: list[tuple[int, float, float]] = []
        for index, value in updates:
            stats = self.stats[index]
            stats.received += 1
            target = self._checked_target(index, value)
            if target is not None:
                accepted.append((index, value, target))
        if not accepted:
            return
        placed_any = False
        with self.lock:
            for index, _, target in accepted:
                joint = self.joints[index]
                placed = self.kinematic or not self.stats[index].accepted
                if self.actuated:
                    if not placed:
                        self.stats[index].add_error(float(self.data.qpos[joint.qpos_address]) - target)
                    self.data.ctrl[joint.actuator_id] = target
                if placed:  # the twin starts where the real joint is, so tracking never counts a start-up jump
                    self.data.qpos[joint.qpos_address] = target
                    self.data.qvel[joint.dof_address] = 0.0
                    placed_any = True
            if placed_any:
                mujoco.mj_forward(self.model, self.data)
        self._record_latency(entered_ns)
        for index, value, _ in accepted:
            stats = self.stats[index]
            stats.accepted += 1
            stats.last_value = value
            stats.last_accepted_at = now
            if self.on_applied is not None:
                self.on_applied(index, value)

    def on_values(self, updates: list[tuple[int, float]], arrived_ns: int) -> None:
        """A transport's values (`ArmEvents`): received as messages are."""
        self.receive(updates, arrived_ns)

    def on_estop(self) -> None:
        """A transport's e-stop (`ArmEvents`): the mirror only watches the arm, so there is nothing to stop."""

    def on_target(self, target: Any) -> None:
        """A transport's task target (`ArmEvents`): the mirror runs no task."""

    def _checked_target(self, index: int, value: float) -> float | None:
        """value + offset, clamped into the joint range within the margin; None (counted) if it is rejected."""
        stats = self.stats[index]
        joint = self.joints[index]
        if not math.isfinite(value):
            stats.rejected_non_finite += 1
            stats.last_rejected_value = value
            return None
        target = joint.to_sim(value)
        if target < joint.low - self.range_margin or target > joint.high + self.range_margin:
            stats.rejected_out_of_range += 1
            stats.last_rejected_value = value
            return None
        if target < joint.low or target > joint.high:
            stats.clamped += 1
            target = min(max(target, joint.low), joint.high)
        return target

    def _record_latency(self, entered_ns: int) -> None:
        if len(self.apply_latency_us) >= APPLY_LATENCY_SAMPLES:
            del self.apply_latency_us[: APPLY_LATENCY_SAMPLES // 2]
        self.apply_latency_us.append((time.perf_counter_ns() - entered_ns) / 1e3)

    def count_unknown(self, name: str) -> None:
        self.unknown_names[name] = self.unknown_names.get(name, 0) + 1

    def track_loss(self, topic: str, publisher_count: Callable[[], int]) -> TopicLoss:
        """The lost-message count of a subscribed topic, whose callback reports each message's sequence number."""
        self.loss[topic] = TopicLoss(publisher_count)
        return self.loss[topic]

    def lost_messages(self) -> int:
        return sum(loss.lost for loss in self.loss.values())

    def loss_warning(self) -> str | None:
        """A line naming the messages lost since the last such line, by topic, or None if there were none."""
        total = self.lost_messages()
        new = total - self.lost_at_last_warning
        if not new:
            return None
        self.lost_at_last_warning = total
        topics = ", ".join(f"{topic} {loss.lost}" for topic, loss in sorted(self.loss.items()) if loss.lost)
        return (
            f"lost {new} messages since the last warning, {total} in all ({topics}): the network dropped them or "
            "the mirror fell behind the publishers and its queues overflowed; the report counts them"
        )

    def update_staleness(self) -> list[MirroredJoint]:
        """Mark joints with no accepted message for `stale_timeout` seconds stale; return those that just became so."""
        now = self.clock()
        became_stale = []
        for joint, stats in zip(self.joints, self.stats, strict=True):
            last = stats.last_accepted_at if stats.last_accepted_at is not None else self.started_at
            stale = now - last > self.stale_timeout
            if stale and not stats.stale:
                stats.stale_episodes += 1
                became_stale.append(joint)
            stats.stale = stale
        return became_stale

    def status_line(self, period: float) -> str:
        """Rate per joint since the last status line, age of its last value, rejections and unknown names."""
        now = self.clock()
        parts = []
        for joint, stats in zip(self.joints, self.stats, strict=True):
            rate = (stats.received - stats.received_at_last_status) / period
            stats.received_at_last_status = stats.received
            age = "never" if stats.last_accepted_at is None else f"{(now - stats.last_accepted_at) * 1e3:.0f}ms"
            flags = " STALE" if stats.stale else ""
            flags += f" rejected {stats.rejected}" if stats.rejected else ""
            parts.append(f"{joint.joint} {rate:.0f}/s {age}{flags}")
        unknown = sum(self.unknown_names.values())
        lost = self.lost_messages()
        tail = f" | unknown {unknown}" if unknown else ""
        tail += f" | lost {lost}" if lost else ""
        return f"[mirror {now - self.started_at:6.1f} s] " + " | ".join(parts) + tail

    def report(self) -> dict[str, Any]:
        """Per-joint statistics, the final state and the tracking error, as JSON-ready data."""
        now = self.clock()
        joints = {}
        with self.lock:
            qpos = self.data.qpos.copy()
            ctrl = self.data.ctrl.copy()
        for joint, stats in zip(self.joints, self.stats, strict=True):
            joints[joint.joint] = {
                "source": joint.source,
                "actuator": joint.actuator,
                "offset": joint.offset,
                "received": stats.received,
                "accepted": stats.accepted,
                "rejected_non_finite": stats.rejected_non_finite,
                "rejected_out_of_range": stats.rejected_out_of_range,
                "clamped": stats.clamped,
                "last_value": stats.last_value,
                "last_rejected_value": _json_float(stats.last_rejected_value),
                "last_age_s": None if stats.last_accepted_at is None else now - stats.last_accepted_at,
                "stale": stats.stale,
                "stale_episodes": stats.stale_episodes,
                "final_qpos": float(qpos[joint.qpos_address]),
                "final_ctrl": float(ctrl[joint.actuator_id]),
                "tracking_error": stats.error_summary() if self.actuated else None,
            }
        return {
            "joints": joints,
            "unknown": dict(sorted(self.unknown_names.items())),
            "malformed_messages": self.malformed,
            "lost_messages": {topic: loss.lost for topic, loss in sorted(self.loss.items())},
            "apply_latency_us": percentiles(self.apply_latency_us),
        }


def percentiles(samples: list[float]) -> dict[str, Any]:
    """Count, median, 99th percentile and largest of latency samples (JSON-ready)."""
    if not samples:
        return {"samples": 0}
    values = np.asarray(samples)
    p50, p99 = np.percentile(values, [50, 99])
    return {"samples": len(samples), "p50": float(p50), "p99": float(p99), "max": float(values.max())}


def _json_float(value: float | None) -> float | str | None:
    """JSON has no NaN or infinity; write those as strings."""
    return value if value is None or math.isfinite(value) else str(value)
