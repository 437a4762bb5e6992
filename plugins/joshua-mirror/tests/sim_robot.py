"""A simulated robot behind ROS 2 topics, for the deploy tests: MuJoCo stepping in real time, encoders out, targets in.

Plan (JSON, argv[1]): {"model": scene.xml, "keyframe": "home", "rate": Hz, "site": "gripper", "target": [x, y, z],
"estop_topic": T, "target_topic": T, "deaf": bool (optional), "lifetime": seconds,
"joints": [{"joint": j, "actuator": a, "encoder": topic, "command": topic, "offset": o, "units": [k, c]}, ...]}.
It publishes each joint's qpos - offset (std_msgs/Float64) on its encoder topic at `rate`, in its units: k * value +
c (optional; default radians, [1, 0]; an arm driven by LeRobot when the test gives LeRobot's scale), applies each
Float64 received on a command topic as its position actuator's ctrl ((value - c) / k + offset), prints "ready", then
every 0.1 s "distance D" (gripper site to target, m). Lines on stdin: "mute" / "unmute" stop and resume the
encoders, "mark" notes how many commands came so far, "estop" publishes true on the e-stop topic and "target X Y Z"
the point on the target topic (geometry_msgs/Point; it becomes the target the distance is measured to), each once a
subscriber is there, "await N" prints "received N" once N commands have come (messages still on their way when the
deploy stopped), "listen" subscribes to the command topics (at once unless the plan says "deaf"), "quit" (or the end
of the lifetime) prints the result as JSON ("result {...}": commands counted, marks, the last command and the
encoder value of each joint, the distance) and exits.
"""

from __future__ import annotations

import json
import sys
import threading
import time

import mujoco
import numpy as np
import rclpy
from geometry_msgs.msg import Point
from rclpy.executors import SingleThreadedExecutor
from std_msgs.msg import Bool, Float64

REPORT_PERIOD_S = 0.1
MATCH_TIMEOUT_S = 30.0


class SimRobot:
    def __init__(self, plan: dict) -> None:
        self.model = mujoco.MjModel.from_xml_path(plan["model"])
        self.data = mujoco.MjData(self.model)
        mujoco.mj_resetDataKeyframe(self.model, self.data, self.model.keyframe(plan["keyframe"]).id)
        mujoco.mj_forward(self.model, self.data)
        self.joints = plan["joints"]
        self.site = self.model.site(plan["site"]).id
        self.target = np.array(plan["target"])
        self.lock = threading.Lock()
        self.muted = False
        self.commands = 0
        self.last_commands = [None] * len(self.joints)  # encoder units, as received
        self.marks: list[int] = []
        self.estop_sent_at: int | None = None  # commands received when the e-stop was published
        self.awaited: int | None = None  # "await N": the command count to report once reached
        self.node = rclpy.create_node("joshua_test_sim_robot")
        self.encoders = [self.node.create_publisher(Float64, joint["encoder"], 10) for joint in self.joints]
        if not plan.get("deaf"):
            self.listen()
        self.estop = self.node.create_publisher(Bool, plan["estop_topic"], 10)
        self.target_publisher = self.node.create_publisher(Point, plan["target_topic"], 10)

    def listen(self) -> None:
        """Subscribe to every joint's command topic."""
        for index, joint in enumerate(self.joints):
            callback = self._on_command(index, self.model.actuator(joint["actuator"]).id, joint)
            self.node.create_subscription(Float64, joint["command"], callback, 100)

    def _on_command(self, index: int, actuator: int, joint: dict):  # noqa: ANN202
        scale, shift = joint.get("units", (1.0, 0.0))

        def apply(message: Float64) -> None:
            with self.lock:
                self.data.ctrl[actuator] = (message.data - shift) / scale + joint["offset"]
                self.commands += 1
                self.last_commands[index] = message.data

        return apply

    def step_until(self, wall: float) -> None:
        with self.lock:
            while self.data.time < wall:
                mujoco.mj_step(self.model, self.data)

    def encoder_values(self) -> list[float]:
        with self.lock:
            return [
                j.get("units", (1.0, 0.0))[0] * (float(self.data.joint(j["joint"]).qpos[0]) - j["offset"])
                + j.get("units", (1.0, 0.0))[1]
                for j in self.joints
            ]

    def publish_encoders(self) -> None:
        values = self.encoder_values()
        if not self.muted:
            for publisher, value in zip(self.encoders, values, strict=True):
                publisher.publish(Float64(data=value))

    def distance(self) -> float:
        with self.lock:  # the target may change (send_target)
            return float(np.linalg.norm(self.data.site_xpos[self.site] - self.target))

    def send_estop(self) -> None:
        wait_for_subscriber(self.estop)
        with self.lock:
            self.estop_sent_at = self.commands
        self.estop.publish(Bool(data=True))

    def send_target(self, target: list[float]) -> None:
        wait_for_subscriber(self.target_publisher)
        with self.lock:
            self.target = np.array(target)
        self.target_publisher.publish(Point(x=target[0], y=target[1], z=target[2]))

    def result(self) -> dict:
        encoders = self.encoder_values()
        with self.lock:
            return {"commands": self.commands, "marks": self.marks, "estop_sent_at": self.estop_sent_at,
                    "last_commands": self.last_commands, "encoders": encoders,
                    "distance": float(np.linalg.norm(self.data.site_xpos[self.site] - self.target))}  # fmt: skip


def wait_for_subscriber(publisher: rclpy.publisher.Publisher) -> None:
    deadline = time.monotonic() + MATCH_TIMEOUT_S
    while publisher.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.01)


def read_stdin(robot: SimRobot, quit_event: threading.Event) -> None:
    for line in sys.stdin:
        word = line.strip()
        if word in ("mute", "unmute"):
            robot.muted = word == "mute"
        elif word == "mark":
            with robot.lock:
                robot.marks.append(robot.commands)
        elif word == "listen":
            robot.listen()
        elif word == "estop":
            robot.send_estop()
        elif word.startswith("await "):
            robot.awaited = int(word.split()[1])
        elif word.startswith("target "):
            robot.send_target([float(value) for value in word.split()[1:]])
        elif word == "quit":
            break
    quit_event.set()


def main() -> None:
    plan = json.loads(sys.argv[1])
    rclpy.init()
    robot = SimRobot(plan)
    executor = SingleThreadedExecutor()
    executor.add_node(robot.node)
    quit_event = threading.Event()

    def spin() -> None:
        while not quit_event.is_set():
            executor.spin_once(timeout_sec=0.05)

    spinner = threading.Thread(target=spin)
    spinner.start()
    threading.Thread(target=read_stdin, args=(robot, quit_event), daemon=True).start()
    print("ready", flush=True)
    period = 1.0 / plan["rate"]
    start = time.monotonic()
    next_report = start
    ticks = 0
    while not quit_event.is_set():
        now = time.monotonic()
        if now - start > plan["lifetime"]:
            quit_event.set()  # a test that waits for a line that never comes fails instead of hanging
        robot.step_until(now - start)
        robot.publish_encoders()
        if robot.awaited is not None and robot.commands >= robot.awaited:
            print(f"received {robot.commands}", flush=True)
            robot.awaited = None
        if now >= next_report:
            next_report = now + REPORT_PERIOD_S
            print(f"distance {robot.distance():.4f}", flush=True)
        ticks += 1
        time.sleep(max(0.0, start + ticks * period - time.monotonic()))
    spinner.join()
    print("result " + json.dumps(robot.result()), flush=True)
    executor.shutdown()
    robot.node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
