"""The deploy node's ROS side: encoder values in (as the mirror reads them), targets out, an e-stop and a target.

Callbacks run on the ROS executor thread: they store each encoder value with its arrival time and wake the
control loop (`wait`). The loop takes a snapshot of the values when every joint has a new one, and publishes
targets on the command topics, in encoder units (target - offset), the way the robot expects them. An arm driven
through LeRobot's follower speaks LeRobot's units (`RobotUnits`): its values become radians as they arrive, and
targets leave in its units.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from joshua_mirror.joints import MirroredJoint
from joshua_mirror.mode import DEFAULT_JOINT_STATE_TOPIC, FLOAT64_TYPE, JOINT_STATE_TYPE, QUEUE_DEPTH
from joshua_mirror.options_pb2 import MirrorOptions
from joshua_mirror.ros import RosSession, message_types, sensor_qos

BOOL_TYPE = "std_msgs/msg/Bool"
POINT_TYPE = "geometry_msgs/msg/Point"
COMMAND_DEPTH = 10  # reliable, keep-last: a robot driver subscribes as it likes


@dataclass(frozen=True)
class RobotUnits:
    """The robot's units: radians (`lerobot` None), or LeRobot's (`joshua_lerobot.LeRobotUnits`, without offsets:
    the mapping's offsets stay the mirror's) for the model joints `features` names (joint -> LeRobot feature)."""

    lerobot: Any = None
    features: dict[str, str] = field(default_factory=dict)

    def to_radians(self, joint: MirroredJoint, value: float) -> float:
        if self.lerobot is None:
            return value
        return float(self.lerobot.to_model(self.features[joint.joint], np.array(value), (joint.low, joint.high)))

    def from_radians(self, joint: MirroredJoint, value: float) -> float:
        if self.lerobot is None:
            return value
        return float(self.lerobot.from_model(self.features[joint.joint], np.array(value), (joint.low, joint.high)))


class RobotLink:
    """Latest encoder values and their arrival times, the e-stop latch and the target; publishes joint targets."""

    def __init__(
        self,
        ros: RosSession,
        joints: list[MirroredJoint],
        options: MirrorOptions,
        commanded: list[MirroredJoint],
        estop_topic: str,
        target_topic: str | None,
        units: RobotUnits | None = None,
    ) -> None:
        self.node = ros.node
        self.joints = joints
        self.units = units or RobotUnits()
        self.commanded = commanded
        self.changed = threading.Condition()
        size = len(joints)
        self.values = np.full(size, np.nan)  # encoder units, in radians
        self.arrived_ns = np.zeros(size, np.int64)  # perf_counter_ns of each value's callback
        self.before = np.full(size, np.nan)  # the value before, and when it came: for the velocity
        self.before_ns = np.zeros(size, np.int64)
        self.fresh = np.zeros(size, bool)  # a value came since the last snapshot
        self.received = np.zeros(size, np.int64)
        self.rejected = np.zeros(size, np.int64)  # NaN or infinite
        self.estop_at: float | None = None  # monotonic seconds of the first e-stop: latched until restart
        self.target: NDArray[np.float64] | None = None
        self.targets_received = 0
        self.expected_types: dict[str, str] = {}
        self._subscribe_encoders(options)
        self._subscribe_controls(estop_topic, target_topic)
        self.float64, _ = message_types()
        self.publishers = [  # every topic name was checked with the config (resolve_joints) or the command line
            self.node.create_publisher(self.float64, joint.command_topic, COMMAND_DEPTH) for joint in commanded
        ]

    def _subscribe(self, kind: Any, type_name: str, topic: str, callback: Any, qos: Any) -> None:
        """Subscribe `callback` to `topic`, whose messages must be `type_name`."""
        self.node.create_subscription(kind, topic, callback, qos)
        self.expected_types[self.node.resolve_topic_name(topic)] = type_name

    def _subscribe_encoders(self, options: MirrorOptions) -> None:
        float64, joint_state = message_types()
        qos = sensor_qos(QUEUE_DEPTH)
        if options.message_type == MirrorOptions.JOINT_STATE:
            topic = options.joint_state_topic or DEFAULT_JOINT_STATE_TOPIC
            by_name = {joint.source: index for index, joint in enumerate(self.joints)}

            def on_joint_state(message: Any) -> None:
                arrived = time.perf_counter_ns()
                pairs = zip(message.name, message.position, strict=False)
                self._store([(by_name[name], value) for name, value in pairs if name in by_name], arrived)

            self._subscribe(joint_state, JOINT_STATE_TYPE, topic, on_joint_state, qos)
            return
        for index, joint in enumerate(self.joints):
            self._subscribe(float64, FLOAT64_TYPE, joint.source, self._float64_callback(index), qos)

    def _subscribe_controls(self, estop_topic: str, target_topic: str | None) -> None:
        from geometry_msgs.msg import Point
        from std_msgs.msg import Bool

        self._subscribe(Bool, BOOL_TYPE, estop_topic, self._on_estop, COMMAND_DEPTH)
        if target_topic:
            self._subscribe(Point, POINT_TYPE, target_topic, self._on_target, COMMAND_DEPTH)

    def _float64_callback(self, index: int) -> Any:
        def on_float64(message: Any) -> None:
            self._store([(index, message.data)], time.perf_counter_ns())

        return on_float64

    def _store(self, updates: list[tuple[int, float]], arrived_ns: int) -> None:
        with self.changed:
            for index, value in updates:
                self.received[index] += 1
                if not np.isfinite(value):
                    self.rejected[index] += 1
                    continue
                self.before[index], self.before_ns[index] = self.values[index], self.arrived_ns[index]
                self.values[index] = self.units.to_radians(self.joints[index], value)
                self.arrived_ns[index] = arrived_ns
                self.fresh[index] = True
            self.changed.notify()

    def _on_estop(self, message: Any) -> None:
        with self.changed:
            if message.data and self.estop_at is None:
                self.estop_at = time.monotonic()
            self.changed.notify()

    def _on_target(self, message: Any) -> None:
        target = np.array([message.x, message.y, message.z])
        with self.changed:
            if np.isfinite(target).all():
                self.target = target
                self.targets_received += 1
            self.changed.notify()

    def wait(self, timeout: float) -> None:
        """Block until a message changes something or `timeout` seconds pass."""
        with self.changed:
            self.changed.wait(max(0.0, timeout))

    def take(self) -> tuple[NDArray[np.float64], NDArray[np.float64], int] | None:
        """When every joint has a new value: the joint positions (sim units), velocities and the newest arrival time
        (perf_counter_ns), and the values count as used; else None.

        A joint's velocity is the difference of its last two values over their arrival times: over the encoder's
        own period, not the (longer) control period, whose average lags enough to make a policy that feeds back
        on velocity oscillate (docs/sim-to-real.md, Deploy)."""
        with self.changed:
            if not self.fresh.all():
                return None
            self.fresh[:] = False
            newest = int(self.arrived_ns.max())
            seconds = (self.arrived_ns - self.before_ns) / 1e9
            known = (self.before_ns > 0) & (seconds > 0)
            velocities = np.where(known, (self.values - self.before) / np.where(known, seconds, 1.0), 0.0)
        return self.positions(), velocities, newest

    def positions(self) -> NDArray[np.float64]:
        """The last value of each joint in sim units (encoder value + offset, as the mirror applies it)."""
        with self.changed:
            values = self.values.copy()
        return np.array([joint.to_sim(value) for joint, value in zip(self.joints, values, strict=True)])

    def ages(self, now_ns: int) -> NDArray[np.float64]:
        """Seconds since each joint's last valid value (infinite before the first)."""
        with self.changed:
            arrived = self.arrived_ns.copy()
        return np.where(arrived > 0, (now_ns - arrived) / 1e9, np.inf)

    def unheard(self) -> list[str]:
        """Command topics that no subscriber has matched yet: what is published there now reaches no one."""
        pairs = zip(self.publishers, self.commanded, strict=True)
        return [joint.command_topic for publisher, joint in pairs if publisher.get_subscription_count() == 0]

    def publish(self, targets: NDArray[np.float64]) -> None:
        """Send each target (sim units, in the order of `commanded`) as target - offset in the robot's units."""
        for publisher, joint, target in zip(self.publishers, self.commanded, targets, strict=True):
            publisher.publish(self.float64(data=self.robot_value(joint, float(target))))

    def robot_value(self, joint: MirroredJoint, target: float) -> float:
        """A target in sim units as the robot reads it: target - offset, in its units."""
        return self.units.from_radians(joint, target - joint.offset)
