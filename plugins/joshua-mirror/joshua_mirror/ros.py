"""rclpy from the package registry, without a ROS install: a clear import error, and one ROS session per run.

The `ros-jazzy-*` wheels need their native libraries on LD_LIBRARY_PATH. Their package
`ros_wheels_bootstrapper` puts them there by itself: a `.pth` file makes every Python of the
virtual environment restart once at startup (os.execve) with LD_LIBRARY_PATH extended and
`_ROS_WHEELS_BOOTSTRAP_COMPLETE=1` set. So nothing has to be sourced; `import_rclpy` only explains
what to do when that restart did not happen (python -S, or a guard variable inherited from another
environment).
"""

from __future__ import annotations

import os
import sys
import sysconfig
import threading
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

from joshua_core.errors import JoshuaError

if TYPE_CHECKING:
    from rclpy.node import Node
    from rclpy.qos import QoSProfile
    from rclpy.subscription import Subscription

ROS_PACKAGES = '"ros-jazzy-rclpy[fastrtps]==7.1.6" ros-jazzy-std-msgs==5.3.6 ros-jazzy-sensor-msgs==5.3.6'
# rcl's own log file (~/.ros/log/*.log, one per process) is not wanted from a simulator; ROS_LOG_DIR still works
# for nodes that enable it.
RCL_ARGS = ["--ros-args", "--disable-external-lib-logs"]
SPIN_TIMEOUT_NS = 50_000_000  # how long the ROS thread waits at most before it looks whether to stop
# Fast DDS drops the samples still on their way when their writer goes away (the mirror missed the replay's last
# row, and a robot the deploy's last targets, about one run in five on a loaded machine): a session that
# publishes keeps its node this long before closing.
DELIVERY_GRACE_S = 0.5


def import_rclpy() -> ModuleType:
    """Import rclpy, or raise JoshuaError saying how to get a working one."""
    try:
        import rclpy
        import rclpy.impl.implementation_singleton  # noqa: F401  (the native part: a broken install fails here)
    except ImportError as error:
        raise JoshuaError(import_problem(error)) from None
    return rclpy


def import_problem(error: ImportError) -> str:
    """What went wrong importing rclpy and what to do about it."""
    if "cannot open shared object file" in str(error):
        library_dirs = ":".join(str(path) for path in ros_library_dirs())
        return (
            f"rclpy is installed but its native libraries are not on LD_LIBRARY_PATH ({error}). The ros-jazzy wheels "
            "set it by restarting Python at startup (ros_wheels_bootstrapper.pth), which did not happen here "
            "(python -S, a package folder outside the virtual environment, or _ROS_WHEELS_BOOTSTRAP_COMPLETE "
            f"inherited). Run: LD_LIBRARY_PATH={library_dirs} joshua ..."
        )
    return f"the MIRROR mode needs rclpy ({error}). Install it: pip install {ROS_PACKAGES}"


def ros_library_dirs() -> list[Path]:
    """The folders the ros-jazzy wheels keep their shared libraries in."""
    site_packages = Path(sysconfig.get_paths()["purelib"])
    return [Path(sys.prefix) / "lib", *sorted(site_packages.glob("ros_*.libs"))]


class RosSession:
    """An rclpy context of our own with one node, whose subscriptions a background thread of ours serves.

    The thread waits on all the node's subscriptions in one rcl wait set and, at each wake-up, takes every
    pending message and calls its subscription's callback at once, independently of whatever the main thread
    does (stepping, rendering), which keeps publish -> applied latency low. A callback of two parameters gets the
    message and its message info (publication sequence number, timestamps), as under rclpy's executors. Only
    subscriptions are served: the node offers no services. Use as a context manager: leaving it stops the thread,
    destroys the node and shuts the context down, also after Ctrl-C.
    """

    # Our own wait-set loop, not rclpy's EventsExecutor: as fast (bench/mirror_latency.py), and it passes the
    # message info that loss counting needs, which rclpy 7.1's EventsExecutor cannot (a two-parameter callback
    # fails there); rclpy's SingleThreadedExecutor passes it but loses most messages at 30,000 msg/s.

    def __init__(self, node_name: str) -> None:
        rclpy = import_rclpy()
        from rclpy.guard_condition import GuardCondition
        from rclpy.parameter import Parameter
        from rclpy.signals import SignalHandlerOptions

        self.context = rclpy.Context()
        # No rclpy signal handlers: Ctrl-C stays Python's KeyboardInterrupt in the main thread.
        rclpy.init(args=RCL_ARGS, context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        try:
            self.node: Node = rclpy.create_node(
                node_name,
                context=self.context,
                start_parameter_services=False,  # nothing would answer them: the thread serves subscriptions
                parameter_overrides=[Parameter("start_type_description_service", value=False)],
            )
        except Exception:
            self.context.try_shutdown()
            raise
        self._wake = GuardCondition(None, None, context=self.context)  # ends a wait early: a new subscription, close
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, name="joshua-mirror-ros", daemon=True)
        self._thread.start()

    def subscribe(self, msg_type: Any, topic: str, callback: Callable[..., None], qos: QoSProfile) -> None:
        """Subscribe the node to `topic`; the thread serves it from its next wake-up, which this one brings on."""
        self.node.create_subscription(msg_type, topic, callback, qos)
        self._wake.trigger()

    def _spin(self) -> None:
        from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

        wait_set: Any = None
        capacity = -1
        while not self._stop.is_set() and self.context.ok():
            subscriptions = list(self.node.subscriptions)  # subscriptions made while it waits join at the next turn
            if len(subscriptions) != capacity:
                capacity = len(subscriptions)
                wait_set = _rclpy.WaitSet(capacity, 1, 0, 0, 0, 0, self.context.handle)
            wait_set.clear_entities()
            for subscription in subscriptions:
                wait_set.add_subscription(subscription.handle)
            wait_set.add_guard_condition(self._wake.handle)
            wait_set.wait(SPIN_TIMEOUT_NS)
            ready = wait_set.get_ready_entities("subscription")
            for subscription in subscriptions:
                if subscription.handle.pointer in ready:
                    _take_pending(subscription)

    def close(self) -> None:
        """Stop the thread, destroy the node, shut the context down (rclpy.shutdown for our context)."""
        if self._stop.is_set():
            return
        if any(True for _ in self.node.publishers):
            time.sleep(DELIVERY_GRACE_S)
        self._stop.set()
        self._wake.trigger()
        self._thread.join()
        for subscription in list(self.node.subscriptions):  # what arrived while it stopped is still applied
            _take_pending(subscription)
        self._wake.destroy()
        self.node.destroy_node()
        self.context.try_shutdown()

    def __enter__(self) -> RosSession:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def _take_pending(subscription: Subscription) -> None:
    """Take the messages waiting in a subscription's queue and call its callback on each, with the message info
    when the callback takes two parameters (what rclpy's executors read from `_callback_type`). At most a queue's
    depth: a flood on one topic never keeps the thread from the others or from stopping."""
    with_info = subscription._callback_type is subscription.CallbackType.WithMessageInfo
    handle, msg_type, raw = subscription.handle, subscription.msg_type, subscription.raw
    callback = subscription.callback
    for _ in range(max(subscription.qos_profile.depth, 1)):
        taken = handle.take_message(msg_type, raw)
        if taken is None:
            return
        if with_info:
            callback(*taken)
        else:
            callback(taken[0])


def sensor_qos(depth: int) -> QoSProfile:
    """Best-effort, keep-last QoS: it matches both reliable and best-effort publishers (what encoders use)."""
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.BEST_EFFORT)


def local_only_environment(domain_id: int) -> dict[str, str]:
    """Environment that keeps DDS traffic on this machine, in its own domain (for tests and benchmarks)."""
    return {**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_DOMAIN_ID": str(domain_id)}


def message_types() -> tuple[Any, Any]:
    """The Float64 and JointState message classes."""
    import_rclpy()
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64

    return Float64, JointState
