"""Encoder set published -> targets received latency of `joshua deploy` over DDS on loopback.

This process plays the robot: it publishes one set of encoder values (six std_msgs/Float64, the topics of the
sim_mirror preset) and notes CLOCK_MONOTONIC right before the first publish; it notes the time again when the
six targets of that set have arrived on the command topics, then waits for the next period (ping-pong, so each
set pairs with its targets). The node under test runs in its own process: `joshua deploy` with the committed
reach policy (observation through the task's terms + MuJoCo's mj_forward, ONNX inference, six publishes), and,
as the reference measured in the same run, a bare rclpy echo node (this script with --echo) that republishes
each encoder message on its command topic: the floor that DDS and rclpy impose on the same 6-in, 6-out path.

    python bench/deploy_latency.py                  # 500 sets per case at 50 Hz
    python bench/deploy_latency.py --sets 2000 --rate 100
"""

from __future__ import annotations

import argparse
import json
import os
import random
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from joshua_core.config import load_preset
from joshua_core.plugins import PluginHost
from joshua_core.resources import models_dir
from joshua_mirror.joints import topic_mappings
from joshua_mirror.ros import local_only_environment

POLICY = models_dir() / "policies" / "so_arm100_reach"
MAPPINGS = topic_mappings(load_preset("sim_mirror", PluginHost.discover().options()).message.simulation)
ENCODERS = [m.ros_topic for m in MAPPINGS]
COMMANDS = [f"/command/{m.mujoco_actuator}" for m in MAPPINGS]
HOME = [0.0, -0.33, 0.37, 1.0, 0.0, 0.4]  # encoder values near the home pose
WARMUP_SETS = 20
REPLY_TIMEOUT_S = 2.0


def run_echo() -> None:
    """Child process: republish every encoder message on its command topic, until SIGINT."""
    import rclpy
    from std_msgs.msg import Float64

    from joshua_mirror.ros import sensor_qos

    rclpy.init()
    node = rclpy.create_node("joshua_bench_echo")
    for encoder, command in zip(ENCODERS, COMMANDS, strict=True):
        publisher = node.create_publisher(Float64, command, 10)
        node.create_subscription(Float64, encoder, lambda message, p=publisher: p.publish(message), sensor_qos(100))
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass


class Robot:
    """Publishes encoder sets and times the replies on the command topics."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from std_msgs.msg import Float64

        rclpy.init()
        self.float64 = Float64
        self.node = rclpy.create_node("joshua_bench_robot")
        self.encoders = [self.node.create_publisher(Float64, topic, 10) for topic in ENCODERS]
        self.replies = 0
        self.lock = threading.Lock()
        self.complete = threading.Event()
        for topic in COMMANDS:
            self.node.create_subscription(Float64, topic, self._on_reply, 100)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._spin)
        self.thread.start()

    def _spin(self) -> None:
        while not self.stop.is_set():
            self.executor.spin_once(timeout_sec=0.05)

    def _on_reply(self, _message: object) -> None:
        with self.lock:
            self.replies += 1
            if self.replies >= len(COMMANDS):
                self.complete.set()

    def ping(self, values: list[float]) -> float | None:
        """Publish one set; microseconds until its targets all arrived (None: no complete reply in time)."""
        with self.lock:
            self.replies = 0
            self.complete.clear()
        sent = time.monotonic_ns()
        for publisher, value in zip(self.encoders, values, strict=True):
            publisher.publish(self.float64(data=value))
        if not self.complete.wait(REPLY_TIMEOUT_S):
            return None
        return (time.monotonic_ns() - sent) / 1e3

    def measure(self, sets: int, rate: float) -> np.ndarray:
        """Latencies of `sets` sets, one per period, after the node answered WARMUP_SETS sets."""
        deadline = time.monotonic() + 60
        while sum(self.ping(HOME) is not None for _ in range(WARMUP_SETS)) < WARMUP_SETS:
            if time.monotonic() > deadline:
                sys.exit("the node under test never answered")
        latencies = []
        start = time.monotonic()
        for index in range(sets):
            time.sleep(max(0.0, start + index / rate - time.monotonic()))
            latency = self.ping([value + 1e-4 * (index % 7) for value in HOME])  # a little motion
            if latency is not None:
                latencies.append(latency)
        return np.asarray(latencies)

    def close(self) -> None:
        self.stop.set()
        self.thread.join()
        self.node.destroy_node()


def config_file(folder: Path) -> Path:
    """The sim_mirror preset with a command topic per actuator (what deploy publishes on)."""
    commands = "".join(
        f'command_topics {{ key: "{m.mujoco_actuator}" value: "{topic}" }} '
        for m, topic in zip(MAPPINGS, COMMANDS, strict=True)
    )
    path = folder / "bench_deploy.pbtxt"
    path.write_text(f'extends: "sim_mirror"\nsimulation {{ mirror {{ {commands}}} }}\n')
    return path


def case(
    name: str, command: list[str], robot: Robot, sets: int, rate: float, env: dict[str, str], cwd: Path
) -> tuple[float, float]:
    """(p50, p99) in microseconds of the node `command` starts."""
    node = subprocess.Popen(command, env=env, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        latencies = robot.measure(sets, rate)
    finally:
        node.send_signal(2)  # SIGINT: deploy writes its report
        node.wait(timeout=30)
    p50, p99 = np.percentile(latencies, [50, 99])
    most = latencies.max()
    print(f"{name:>6}: {len(latencies)}/{sets} sets, p50 {p50:7.0f} us, p99 {p99:7.0f} us, max {most:7.0f} us")
    return float(p50), float(p99)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sets", type=int, default=500)
    parser.add_argument("--rate", type=float, default=50.0, help="sets per second")
    parser.add_argument("--echo", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.echo:
        run_echo()
        return
    os.environ.update(local_only_environment(random.randint(101, 200)))
    joshua = str(Path(sys.executable).parent / "joshua")
    robot = Robot()
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        deploy = [joshua, "deploy", str(POLICY), "--config", str(config_file(work)), "--target", "0.22,0.05,0.15",
                  "--rate", "1000", "--max-speed", "100", "--stale-after", "1"]  # fmt: skip
        echo_p50, echo_p99 = case("echo", [sys.executable, __file__, "--echo"], robot, args.sets, args.rate,
                                  dict(os.environ), work)  # fmt: skip
        deploy_p50, deploy_p99 = case("deploy", deploy, robot, args.sets, args.rate, dict(os.environ), work)
        (report,) = work.glob("joshua_output/deploy_*/deploy_report.json")
        inside = json.loads(report.read_text())["latency_us"]
    robot.close()
    print(f"deploy / echo: p50 x{deploy_p50 / echo_p50:.1f}, p99 x{deploy_p99 / echo_p99:.1f}")
    for name, stats in inside.items():
        print(f"inside deploy, {name}: p50 {stats['p50']:.0f} us, p99 {stats['p99']:.0f} us ({stats['samples']} steps)")


if __name__ == "__main__":
    main()
