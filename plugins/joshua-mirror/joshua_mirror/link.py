"""The deploy's view of the arm (`RobotLink`) and its ROS 2 transport (`RosTransport`).

`RobotLink` keeps what any transport delivers: each joint's latest value (radians, before the offset) with its
arrival time, the e-stop latch and the target; the control loop takes a snapshot when every joint has a new value
and sends targets back through the transport. `RosTransport` is the arm behind topics: encoder values in (as the
mirror reads them), targets out on the command topics, in encoder units (target - offset), the e-stop and target
topics; an arm driven through LeRobot's follower over ROS speaks LeRobot's units (`RobotUnits`), converted on the
way in and out. Callbacks run on the ROS thread.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from joshua_mirror.graph import TypeChecker
from joshua_mirror.joints import MirroredJoint
from joshua_mirror.mode import DEFAULT_JOINT_STATE_TOPIC, FLOAT64_TYPE, JOINT_STATE_TYPE, QUEUE_DEPTH
from joshua_mirror.options_pb2 import MirrorOptions
from joshua_mirror.ros import RosSession, message_types, sensor_qos
from joshua_mirror.transport import ArmEvents, ArmTransport, RobotUnits

BOOL_TYPE = "std_msgs/msg/Bool"
POINT_TYPE = "geometry_msgs/msg/Point"
COMMAND_DEPTH = 10  # reliable, keep-last: a robot driver subscribes as it likes


class RobotLink:
    """Latest joint values and their arrival times, the e-stop latch and the target, from `transport`; sends the
    targets of the `commanded` joints through it."""

    def __init__(self, transport: ArmTransport, commanded: list[MirroredJoint]) -> None:
        self.transport = transport
        self.joints = transport.joints
        self.commanded = commanded
        self.changed = threading.Condition()
        size = len(self.joints)
        self.values = np.full(size, np.nan)  # radians, before the offset
        self.arrived_ns = np.zeros(size, np.int64)  # perf_counter_ns of each value's arrival
        self.before = np.full(size, np.nan)  # the value before, and when it came: for the velocity
        self.before_ns = np.zeros(size, np.int64)
        self.fresh = np.zeros(size, bool)  # a value came since the last snapshot
        self.received = np.zeros(size, np.int64)
        self.rejected = np.zeros(size, np.int64)  # NaN or infinite
        self.estop_at: float | None = None  # monotonic seconds of the first e-stop: latched until restart
        self.target: NDArray[np.float64] | None = None
        self.targets_received = 0
        transport.start(self)

    def on_values(self, updates: list[tuple[int, float]], arrived_ns: int) -> None:
        with self.changed:
            for index, value in updates:
                self.received[index] += 1
                if not np.isfinite(value):
                    self.rejected[index] += 1
                    continue
                self.before[index], self.before_ns[index] = self.values[index], self.arrived_ns[index]
                self.values[index] = value
                self.arrived_ns[index] = arrived_ns
                self.fresh[index] = True
            self.changed.notify()

    def on_estop(self) -> None:
        with self.changed:
            if self.estop_at is None:
                self.estop_at = time.monotonic()
            self.changed.notify()

    def on_target(self, target: NDArray[np.float64]) -> None:
        with self.changed:
            if np.isfinite(target).all():
                self.target = target
                self.targets_received += 1
            self.changed.notify()

    def wait(self, timeout: float) -> None:
        """Block until a value, e-stop or target changes something or `timeout` seconds pass."""
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
        """The last value of each joint in sim units (value + offset, as the mirror applies it)."""
        with self.changed:
            values = self.values.copy()
        return np.array([joint.to_sim(value) for joint, value in zip(self.joints, values, strict=True)])

    def ages(self, now_ns: int) -> NDArray[np.float64]:
        """Seconds since each joint's last valid value (infinite before the first)."""
        with self.changed:
            arrived = self.arrived_ns.copy()
        return np.where(arrived > 0, (now_ns - arrived) / 1e9, np.inf)

    def unheard(self) -> list[str]:
        return self.transport.unheard()

    def publish(self, targets: NDArray[np.float64]) -> None:
        """Send each target (sim units, in the order of `commanded`) as target - offset."""
        offsets = np.array([joint.offset for joint in self.commanded])
        self.transport.send(self.commanded, np.asarray(targets) - offsets)


class RosTransport(ArmTransport):
    """The arm behind ROS 2 topics: encoders (Float64 per joint or one JointState), command topics (Float64), the
    e-stop (Bool) and target (Point) topics; a publisher of another type on any of them stops the run."""

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
        self.ros = ros
        self.node = ros.node
        self.joints = joints
        self.options = options
        self.units = units or RobotUnits()
        self.estop_topic, self.target_topic = estop_topic, target_topic
        self.expected_types: dict[str, str] = {}
        self.float64, _ = message_types()
        self.commanded = commanded
        self.publishers = {  # every topic name was checked with the config (resolve_joints) or the command line
            joint.joint: self.node.create_publisher(self.float64, joint.command_topic, COMMAND_DEPTH)
            for joint in commanded
        }
        self.types: TypeChecker | None = None

    def start(self, events: ArmEvents) -> None:
        self._subscribe_encoders(events)
        self._subscribe_controls(events)
        self.types = TypeChecker(self.node, self.expected_types, reader="deploy")

    def _subscribe(self, kind: Any, type_name: str, topic: str, callback: Any, qos: Any) -> None:
        """Subscribe `callback` to `topic`, whose messages must be `type_name`."""
        self.node.create_subscription(kind, topic, callback, qos)
        self.expected_types[self.node.resolve_topic_name(topic)] = type_name

    def _subscribe_encoders(self, events: ArmEvents) -> None:
        float64, joint_state = message_types()
        qos = sensor_qos(QUEUE_DEPTH)
        if self.options.message_type == MirrorOptions.JOINT_STATE:
            topic = self.options.joint_state_topic or DEFAULT_JOINT_STATE_TOPIC
            by_name = {joint.source: index for index, joint in enumerate(self.joints)}

            def on_joint_state(message: Any) -> None:
                arrived = time.perf_counter_ns()
                pairs = zip(message.name, message.position, strict=False)
                events.on_values([self._radians(by_name[n], v) for n, v in pairs if n in by_name], arrived)

            self._subscribe(joint_state, JOINT_STATE_TYPE, topic, on_joint_state, qos)
            return
        for index, joint in enumerate(self.joints):
            self._subscribe(float64, FLOAT64_TYPE, joint.source, self._float64_callback(events, index), qos)

    def _radians(self, index: int, value: float) -> tuple[int, float]:
        return index, self.units.to_radians(self.joints[index], value) if np.isfinite(value) else value

    def _float64_callback(self, events: ArmEvents, index: int) -> Any:
        def on_float64(message: Any) -> None:
            events.on_values([self._radians(index, message.data)], time.perf_counter_ns())

        return on_float64

    def _subscribe_controls(self, events: ArmEvents) -> None:
        from geometry_msgs.msg import Point
        from std_msgs.msg import Bool

        def on_estop(message: Any) -> None:
            if message.data:
                events.on_estop()

        def on_target(message: Any) -> None:
            events.on_target(np.array([message.x, message.y, message.z]))

        self._subscribe(Bool, BOOL_TYPE, self.estop_topic, on_estop, COMMAND_DEPTH)
        if self.target_topic:
            self._subscribe(Point, POINT_TYPE, self.target_topic, on_target, COMMAND_DEPTH)

    def send(self, joints: Any, targets: NDArray[np.float64]) -> None:
        for joint, target in zip(joints, targets, strict=True):
            value = self.units.from_radians(joint, float(target))
            self.publishers[joint.joint].publish(self.float64(data=value))

    def unheard(self) -> list[str]:
        """Command topics that no subscriber has matched yet: what is published there now reaches no one."""
        return [
            joint.command_topic
            for joint in self.commanded
            if self.publishers[joint.joint].get_subscription_count() == 0
        ]

    def poll(self) -> list[str]:
        assert self.types is not None
        return [f"wrong message type: {line}" for line in self.types.poll()]

    def broken(self) -> str | None:
        return "wrong message type" if self.types and self.types.current else None

    def error(self) -> str | None:
        return self.types.error() if self.types else None

    def close(self) -> None:
        self.ros.close()

    def report(self) -> dict[str, Any]:
        return {"estop_topic": self.estop_topic, "target_topic": self.target_topic,
                "type_mismatches": self.types.seen if self.types else {}}  # fmt: skip
