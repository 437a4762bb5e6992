"""A real ROS 2 publisher process for the tests: publishes the messages of a JSON plan, then exits.

Plan: {"wait_for": TOPIC, "messages": [{"topic": T, "value": V} | {"topic": T, "names": [...], "positions":
[...]} | {"topic": T, "type": "Float32" | "String", "value": V} | {"sleep": S} | {"topic": T, "burst": [V, ...]}
| {"await": LINE} | {"topic": T, "value": V, "until_read": LINE}, ...]}. Values may be "nan"/"inf". A burst
publishes its Float64 values back to back, as fast as it can; "await" prints LINE and waits for a line on stdin
(the test's go-ahead); "until_read" publishes its message, prints LINE and publishes it again for every "again"
line on stdin, until an empty line. It first waits until TOPIC has a subscriber (the mirror), so no message is
published before the mirror listens. With "hold": true instead of "wait_for" it creates the publishers, prints
"ready" and stays until SIGINT (for publishers of a type the mirror does not read, which no subscriber ever
matches).
"""

from __future__ import annotations

import json
import sys
import time

import rclpy
import rclpy.executors
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float32, Float64, String

MATCH_TIMEOUT_S = 30.0
GAP_S = 0.002  # between messages, so a best-effort subscriber keeps up
SETTLE_S = 1.0  # after the publisher's side matched, for the mirror's side (main's comment says why)
OTHER_TYPES = {"Float32": Float32, "String": String}


def main() -> None:
    plan = json.loads(sys.argv[1])
    rclpy.init()
    node = rclpy.create_node("joshua_mirror_test_publisher")
    qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
    publishers = {}

    def publisher(topic: str, kind: type) -> rclpy.publisher.Publisher:
        if topic not in publishers:
            publishers[topic] = node.create_publisher(kind, topic, qos)
        return publishers[topic]

    for message in plan["messages"]:  # create them all first, so discovery happens once
        if "topic" in message:
            kind = JointState if "names" in message else OTHER_TYPES.get(message.get("type", ""), Float64)
            publisher(message["topic"], kind)
    if plan.get("hold"):
        print("ready", flush=True)
        try:
            rclpy.spin(node)
        except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
            pass
        return
    watched = publishers[plan["wait_for"]]
    deadline = time.monotonic() + MATCH_TIMEOUT_S
    while watched.get_subscription_count() == 0:
        if time.monotonic() > deadline:
            sys.exit(f"no subscriber on {plan['wait_for']} after {MATCH_TIMEOUT_S} s")
        time.sleep(0.02)
    # the other topics the mirror reads, once it reads the watched one (a topic of a type it does not read never
    # matches: not waited for)
    others = [sent for sent in publishers.values() if sent.msg_type is watched.msg_type]
    while any(sent.get_subscription_count() == 0 for sent in others) and time.monotonic() < deadline:
        time.sleep(0.02)
    # A publisher sees only its own side of a match: the mirror's best-effort reader drops what arrives before it
    # has matched the publisher in turn, which rclpy cannot observe from here. 0.2 s lost one message of 40 in
    # about one CI run of two on 2 loaded cores; SETTLE_S leaves five times that.
    time.sleep(SETTLE_S)
    for message in plan["messages"]:
        if "sleep" in message:
            time.sleep(message["sleep"])
            continue
        if "await" in message:
            print(message["await"], flush=True)
            sys.stdin.readline()
            continue
        if "burst" in message:
            burst_publisher = publishers[message["topic"]]
            for value in message["burst"]:
                burst_publisher.publish(Float64(data=float(value)))
            continue
        if "names" in message:
            ros_message = JointState(name=message["names"], position=[float(p) for p in message["positions"]])
        else:
            ros_message = Float64(data=float(message["value"]))
        publishers[message["topic"]].publish(ros_message)
        while "until_read" in message:
            print(message["until_read"], flush=True)
            if sys.stdin.readline().strip() != "again":
                break
            publishers[message["topic"]].publish(ros_message)
        time.sleep(GAP_S)
    time.sleep(0.2)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
