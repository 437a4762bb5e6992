"""Publish -> simulation-state-updated latency of the MIRROR mode over DDS on loopback.

A publisher process (this script with --publisher) sends N messages at a fixed rate, noting the
CLOCK_MONOTONIC time (system-wide, so comparable across processes) right before each publish().
This process runs the mirror's own subscription code (`joshua_mirror.mode.MirrorTopics` feeding a
`Mirror` on the SO-ARM100 of the sim_mirror preset, KINEMATIC: qpos written + mj_forward) and notes
the time right after the state was updated. Each message carries a unique value, which pairs the
two. Reference, measured in the same run: a bare rclpy subscription whose callback only notes the
time (the floor DDS + rclpy impose). Goal: mirror p99 < 1 ms.

    python bench/mirror_latency.py                  # 2000 messages per case at 500 Hz
    python bench/mirror_latency.py --messages 5000 --rate 1000
"""

from __future__ import annotations

import argparse
import json
import os
import random
import subprocess
import sys
import time
from typing import Any

import numpy as np

from joshua_core.config import finalize, load_preset
from joshua_core.options import options_of
from joshua_core.plugins import PluginHost
from joshua_mirror import options_pb2
from joshua_mirror.options_pb2 import MirrorOptions
from joshua_mirror.ros import local_only_environment

GOAL_P99_US = 1000.0
MATCH_TIMEOUT_S = 30.0


def value_of(index: int) -> float:
    """A unique encoder value per message, inside joint_1's range (for up to 290,000 messages)."""
    return -1.0 + index * 1e-5


def run_publisher(topic: str, joint_state: bool, count: int, rate: float) -> None:
    """Child process: publish `count` messages on `topic`, print [[value, t_ns], ...] as JSON."""
    import rclpy
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64

    rclpy.init()
    node = rclpy.create_node("joshua_mirror_bench_publisher")
    publisher = node.create_publisher(
        JointState if joint_state else Float64, topic, QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
    )
    deadline = time.monotonic() + MATCH_TIMEOUT_S
    while publisher.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.5)  # let the subscriber's side of the match complete
    names = [f"joint_{i}" for i in range(1, 7)]
    sent = []
    start = time.monotonic()
    for index in range(count):
        value = value_of(index)
        if joint_state:
            message = JointState(name=names, position=[value, 0.0, 0.0, 0.5, 0.0, 0.5])
        else:
            message = Float64(data=value)
        delay = start + index / rate - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        sent.append((value, time.monotonic_ns()))
        publisher.publish(message)
    time.sleep(0.3)
    node.destroy_node()
    rclpy.shutdown()
    print(json.dumps(sent))


def measure(case: str, topic: str, joint_state: bool, count: int, rate: float, env: dict[str, str]) -> np.ndarray:
    """Latencies in microseconds of one case (`raw` or `mirror`), publisher in a child process."""
    from rclpy.qos import qos_profile_sensor_data

    from joshua_mirror.mirror import Mirror
    from joshua_mirror.mode import MirrorTopics
    from joshua_mirror.ros import RosSession, message_types
    from joshua_mujoco import MuJoCoEngine

    received: dict[float, int] = {}
    config = finalize(load_preset("sim_mirror", PluginHost.discover().options())).simulation
    options = options_of(config, options_pb2.mirror)
    options.message_type = MirrorOptions.JOINT_STATE if joint_state else MirrorOptions.FLOAT64
    options.status_period = -1
    with MuJoCoEngine(config.model_path) as engine, RosSession("joshua_mirror_bench") as ros:
        if case == "raw":
            float64, joint_state_type = message_types()

            def on_message(message: Any) -> None:
                now = time.monotonic_ns()
                received[message.position[0] if joint_state else message.data] = now

            ros.node.create_subscription(
                joint_state_type if joint_state else float64, topic, on_message, qos_profile_sensor_data
            )
        else:
            from joshua_mirror.joints import resolve_joints, topic_mappings

            joints = resolve_joints(engine.model, topic_mappings(config), options)
            mirror = Mirror(engine.model, engine.data, joints, options, stale_timeout=1.0)

            def on_applied(index: int, value: float) -> None:
                if index == 0:
                    received[value] = time.monotonic_ns()

            mirror.on_applied = on_applied
            MirrorTopics(ros, mirror, options, None).start(mirror)
        publisher = subprocess.run(
            [
                sys.executable,
                __file__,
                "--publisher",
                topic,
                "--joint-state" if joint_state else "--float64",
                "--messages",
                str(count),
                "--rate",
                str(rate),
            ],
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
            check=True,
        )
        counted = f", the mirror counted {mirror.lost_messages()} lost" if case == "mirror" else ""
        if case == "mirror" and value_of(count - 1) in received:
            assert abs(engine.data.qpos[joints[0].qpos_address] - (value_of(count - 1) + joints[0].offset)) < 1e-9
    sent = json.loads(publisher.stdout)
    latencies = [(received[value] - sent_ns) / 1e3 for value, sent_ns in sent if value in received]
    lost = len(sent) - len(latencies)
    if lost:
        print(f"  ({case}: {lost} of {len(sent)} messages not received{counted})")
    return np.asarray(latencies)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--messages", type=int, default=2000)
    parser.add_argument("--rate", type=float, default=500.0, help="messages per second")
    parser.add_argument("--publisher", metavar="TOPIC", help=argparse.SUPPRESS)
    parser.add_argument("--joint-state", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--float64", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.publisher:
        run_publisher(args.publisher, args.joint_state, args.messages, args.rate)
        return
    env = local_only_environment(random.randint(101, 200))
    os.environ.update(env)  # our own node joins the same local-only domain
    print(f"{args.messages} messages per case at {args.rate:g} Hz, loopback, ROS_DOMAIN_ID={env['ROS_DOMAIN_ID']}")
    print(f"{'case':<28} {'p50 us':>8} {'p99 us':>8} {'max us':>8}  p99 vs bare rclpy")
    for message, topic, joint_state in (
        ("Float64", "/encoder/joint_1", False),
        ("JointState", "/joint_states", True),
    ):
        raw = measure("raw", topic, joint_state, args.messages, args.rate, env)
        mirrored = measure("mirror", topic, joint_state, args.messages, args.rate, env)
        for label, latencies in ((f"bare rclpy, {message}", raw), (f"mirror (KINEMATIC), {message}", mirrored)):
            p50, p99 = np.percentile(latencies, [50, 99])
            ratio = p99 / np.percentile(raw, 99)
            verdict = "" if latencies is raw else ("  ok" if p99 < GOAL_P99_US else "  OVER GOAL (p99 < 1000 us)")
            print(f"{label:<28} {p50:8.0f} {p99:8.0f} {latencies.max():8.0f}  {ratio:5.2f}x{verdict}")


if __name__ == "__main__":
    main()
