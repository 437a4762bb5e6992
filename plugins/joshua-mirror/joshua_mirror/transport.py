"""How a real arm is reached: `ArmTransport`, one small interface that ROS 2 topics and a LeRobot robot both fill.

The deploy loop (rate, stale joints, maximum speed, stops and e-stop, joint limits) and the mirror work on what a
transport delivers and never on how: joint values in radians (before the mapping's offset) with their arrival
time, an e-stop, a target; and, for the deploy, targets sent back in the same radians. A transport converts its
own units (`RobotUnits`) on the way in and out, so the safety is written once for both.
"""

from __future__ import annotations

import abc
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from joshua_mirror.joints import MirroredJoint


class ArmEvents(Protocol):
    """What a transport tells its reader, from whichever thread it reads on."""

    def on_values(self, updates: list[tuple[int, float]], arrived_ns: int) -> None:
        """Joint values (index into the transport's joints, radians before the offset), read at `arrived_ns`."""

    def on_estop(self) -> None:
        """Stop the arm in place and stay stopped until restart."""

    def on_target(self, target: NDArray[np.float64]) -> None:
        """A new task target (model frame, metres)."""


class ArmTransport(abc.ABC):
    """One real arm: its values come in through `start`'s events; `send` moves it (deploy only)."""

    joints: list[MirroredJoint]
    units: RobotUnits  # what the arm's values are in

    @abc.abstractmethod
    def start(self, events: ArmEvents) -> None:
        """Begin delivering values (and e-stops, targets) to `events`, on a thread of the transport's own."""

    def send(self, joints: Sequence[MirroredJoint], targets: NDArray[np.float64]) -> None:
        """Send each joint its target (radians before the offset), all in one go."""
        raise NotImplementedError(f"{type(self).__name__} only reads the arm")

    def unheard(self) -> list[str]:
        """Where targets would be lost now (no one listening yet); empty when every target arrives."""
        return []

    def poll(self) -> list[str]:
        """Lines about problems that are new since the last poll (called every status period)."""
        return []

    def broken(self) -> str | None:
        """What stops the run now (e.g. "wrong message type"), or None; `error` then says it in full."""
        return None

    def error(self) -> str | None:
        """One line for what went wrong during the run, or None: the command then exits 2 with it."""
        return None

    def status(self) -> str:
        """The status line's part of the transport ('' when nothing to say)."""
        return ""

    def page(self) -> list[str]:
        """The transport's lines (Markdown) on the mirror's status web page: by default the status line's part."""
        status = self.status().removeprefix(" | ")
        return [f"- {status}"] if status else []

    def report(self) -> dict[str, Any]:
        """What the report keeps of the transport."""
        return {}

    @abc.abstractmethod
    def close(self) -> None:
        """Stop delivering and let go of the arm, leaving it holding its last target (twice is once)."""


@dataclass(frozen=True)
class RobotUnits:
    """The robot's units: radians (`lerobot` None), or LeRobot's (`joshua_lerobot.LeRobotUnits`, without offsets:
    the mapping's offsets stay the mirror's) for the model joints `features` names (joint -> LeRobot feature), of
    the LeRobot arm `robot_type` whose joints the model has (`joshua_lerobot.feature_names`)."""

    lerobot: Any = None
    features: dict[str, str] = field(default_factory=dict)
    robot_type: str | None = None

    def to_radians(self, joint: MirroredJoint, value: float) -> float:
        if self.lerobot is None:
            return value
        return float(self.lerobot.to_model(self.features[joint.joint], np.array(value), (joint.low, joint.high)))

    def from_radians(self, joint: MirroredJoint, value: float) -> float:
        if self.lerobot is None:
            return value
        return float(self.lerobot.from_model(self.features[joint.joint], np.array(value), (joint.low, joint.high)))
