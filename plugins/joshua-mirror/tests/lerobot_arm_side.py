"""Runs `joshua deploy --lerobot` and the MIRROR mode on LeRobot arms that are `feetech_bus.FeetechArm`s, with the
real lerobot (started by conftest.py's `lerobot_side` with lerobot's site on PYTHONPATH): each scenario is the real
command (`joshua_core.cli.main`) in this one process, so lerobot and torch are imported once for a group. Prints one
JSON line: per scenario its exit status, stderr lines and what the arm saw.

    python lerobot_arm_side.py deploy OUT_DIR   joshua deploy --lerobot on an SO-100 follower
    python lerobot_arm_side.py mirror OUT_DIR   the mirror of an SO-101 follower, and an SO-101 leader teleoperating
                                                the simulated arm into a LeRobot dataset that lerobot then loads
"""

from __future__ import annotations

import io
import json
import os
import re
import signal
import sys
import threading
from collections.abc import Callable
from contextlib import redirect_stderr
from pathlib import Path
from typing import Any

from feetech_bus import MOTORS, FeetechArm

from joshua_core.cli import main
from joshua_core.resources import models_dir

POLICY = models_dir() / "policies" / "so_arm100_reach"
TARGET = "0.22,0.05,0.15"
RANGE = (1024, 3072)  # every motor's calibrated range, ticks: its middle 2048 is the model's zero
WAIT_S = 30.0  # a line that never comes fails the scenario, it does not hang


class Lines(io.TextIOBase):
    """stderr as lines, kept and watched: `wait_for` blocks until a line matching a pattern was written."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.partial = ""
        self.ended = False  # the command returned: no line will come
        self.changed = threading.Condition()

    def write(self, text: str) -> int:
        with self.changed:
            *done, self.partial = (self.partial + text).split("\n")
            self.lines.extend(done)
            self.changed.notify_all()
        return len(text)

    def wait_for(self, pattern: str, after: int = 0) -> int:
        """The index of the first line from `after` on that matches `pattern`."""
        with self.changed:
            self.changed.wait_for(lambda: self.ended or self._find(pattern, after) is not None, WAIT_S)
            if self._find(pattern, after) is None:
                raise TimeoutError(f"no line matching {pattern!r}")
            return self._find(pattern, after)  # type: ignore[return-value]

    def end(self) -> None:
        with self.changed:
            self.ended = True
            self.changed.notify_all()

    def _find(self, pattern: str, after: int) -> int | None:
        return next((i for i, line in enumerate(self.lines[after:], after) if re.search(pattern, line)), None)


def calibration(folder: Path, name: str = "arm") -> Path:
    path = folder / f"{name}.json"
    entries = {
        motor: {"id": index, "drive_mode": 0, "homing_offset": 0, "range_min": RANGE[0], "range_max": RANGE[1]}
        for index, motor in enumerate(MOTORS, 1)
    }
    path.write_text(json.dumps(entries))
    return path


def calibrated_arm(ticks: dict[int, float] | None = None) -> FeetechArm:
    """An arm whose servos hold the calibration `calibration` writes (lerobot-calibrate wrote both)."""
    arm = FeetechArm(ticks)
    for servo in arm.servos.values():
        servo.memory[9:11] = RANGE[0].to_bytes(2, "little")
        servo.memory[11:13] = RANGE[1].to_bytes(2, "little")
    return arm


def run(argv: list[str], driver: Callable[[Lines], None] | None = None) -> dict[str, Any]:
    """`joshua ARGV` on this (main) thread, its stderr watched by `driver` on another; exit status and lines."""
    lines = Lines()
    failure: list[str] = []

    def drive() -> None:
        try:
            assert driver is not None
            driver(lines)
        except Exception as error:  # reported, and the command stopped if it still runs: the test fails on it
            failure.append(repr(error))
            with lines.changed:
                if not lines.ended:
                    os.kill(os.getpid(), signal.SIGINT)

    thread = threading.Thread(target=drive) if driver else None
    with redirect_stderr(lines):
        if thread:
            thread.start()
        try:
            status = main(argv)
        except SystemExit as exit_:
            status = int(exit_.code or 0)
        lines.end()
        if thread:
            try:
                thread.join()
            except KeyboardInterrupt:  # the driver's stop, sent as the command ended: it had nothing to stop
                thread.join()
    return {"status": status, "lines": lines.lines, "driver_failed": failure}


def follow(arm: FeetechArm, reads: int) -> list[dict[int, int]]:
    """The servos' positions at each of the next `reads` reads: the path the policy moves the arm along."""
    path = []
    for _ in range(reads):
        assert arm.wait_reads(1, WAIT_S), "the arm is no longer read"
        path.append(arm.ticks())
    return path


def deploy_scenarios(out: Path) -> dict[str, Any]:
    results: dict[str, Any] = {}
    good = calibration(out)
    base = ["deploy", str(POLICY), "--lerobot", "so100_follower", "--target", TARGET, "--status-period", "0.1"]
    with calibrated_arm() as arm:

        def drive(lines: Lines) -> None:
            running = lines.wait_for(r"deploy: RUNNING")
            assert arm.wait_reads(20, WAIT_S)
            arm.muted.set()  # the arm stops answering: the deploy holds
            held = lines.wait_for(r"deploy: HOLD", running)
            assert arm.wait_reads(1, WAIT_S)  # the bus is in order: every goal sent before the HOLD has arrived
            results["goals_at_hold"] = arm.goals_written
            lines.wait_for(r"does not answer", running)
            lines.wait_for(r"\[deploy .* HOLD", held)  # a status period in HOLD
            results["goals_before_answering"] = arm.goals_written
            arm.muted.clear()
            again = lines.wait_for(r"deploy: RUNNING", held)
            lines.wait_for(r"answers again", running)
            results["path"] = follow(arm, 150)  # time to reach the target
            os.kill(os.getpid(), signal.SIGUSR1)  # the e-stop
            lines.wait_for(r"deploy: E-STOP", again)
            assert arm.wait_reads(1, WAIT_S)  # the stop in place has arrived
            results["goals_at_estop"] = arm.goals_written
            assert arm.wait_reads(20, WAIT_S)
            results["goals_after_estop"] = arm.goals_written
            os.kill(os.getpid(), signal.SIGTERM)

        argv = [*base, "--port", arm.port, "--calibration", str(good), "--output-dir", str(out), "--run-name", "ok"]
        results["run"] = run(argv, drive)
        results["ticks"] = arm.ticks()
        results["goals"] = arm.goals()
        results["goal_writes"] = arm.goal_writes
        results["torque"] = arm.torque()
    results["report"] = json.loads((out / "ok" / "deploy_report.json").read_text())
    results["bad_port"] = run([*base, "--port", str(out / "ttyACM9"), "--calibration", str(good)])
    with calibrated_arm() as arm:
        results["no_calibration"] = run([*base, "--port", arm.port, "--calibration", str(out / "missing.json")])
        for servo in arm.servos.values():
            servo.memory[11:13] = (RANGE[1] - 100).to_bytes(2, "little")  # this arm was calibrated otherwise
        results["other_calibration"] = run([*base, "--port", arm.port, "--calibration", str(good)])
        results["other_torque"] = arm.torque()
    with calibrated_arm() as arm:
        arm.muted.set()
        results["silent"] = run([*base, "--port", arm.port, "--calibration", str(good)])
        results["silent_torque"] = arm.torque()
    return results


MIRROR = [
    "--preset",
    "so101_sim_mirror",
    "--set",
    "simulation.mirror.display=NONE",
    "--set",
    "simulation.mirror.status_period=0.1",
]
POSE_A = {1: 2300, 2: 1800, 3: 2500, 4: 1700, 5: 2200, 6: 1900}  # ticks of servos 1..6, inside every joint's range
POSE_B = {1: 1800, 2: 2250, 3: 1750, 4: 2400, 5: 1900, 6: 2350}
TELEOP_PERIODS = 6  # status periods (0.1 s) at the second pose: time for the simulated arm to get there
TELEOP_FPS = 10  # few frames: the dataset's video is rendered in software
ALL_READ = r"^\[mirror (?!.*never)"  # a status line once every joint has a value


def arm_sets(robot_type: str, port: str, calibration_file: Path) -> list[str]:
    """`--set`s of `simulation.mirror.lerobot`: the arm `robot_type` on `port`, calibrated as `calibration_file`."""
    values = {"robot_type": robot_type, "port": port, "calibration": str(calibration_file)}
    return [arg for name, value in values.items() for arg in ("--set", f"simulation.mirror.lerobot.{name}={value}")]


def place(arm: FeetechArm, pose: dict[int, int]) -> None:
    for servo, ticks in pose.items():
        arm.place(servo, ticks)


def follow_then(arm: FeetechArm, poses: list[tuple[dict[int, int], int]]) -> Callable[[Lines], None]:
    """A driver: once every joint has a value, put the arm in each of `poses` (pose, status periods) in turn, each
    until the mirror has read it (later reads came) and its status periods passed; then Ctrl-C."""

    def drive(lines: Lines) -> None:
        lines.wait_for(ALL_READ)
        for pose, periods in poses:
            place(arm, pose)
            assert arm.wait_reads(3, WAIT_S)  # the reader read the pose and handed it on before it read again
            seen = len(lines.lines) - 1  # the status lines from here on came after the mirror had the pose
            for _ in range(periods):
                seen = lines.wait_for(ALL_READ, seen + 1)
        os.kill(os.getpid(), signal.SIGINT)

    return drive


def mirror_scenarios(out: Path) -> dict[str, Any]:
    """The twin follows a follower read through LeRobot; a leader teleoperates the simulated arm, recorded as a
    LeRobot dataset that lerobot loads; the refusals."""
    results: dict[str, Any] = {}
    good = calibration(out)
    record = ["--set", "simulation.mirror.record.csv=true", "--set", f"simulation.output_dir={out}/f"]
    with calibrated_arm(dict(POSE_A)) as arm:
        argv = [*MIRROR, *arm_sets("so101_follower", arm.port, good), *record]
        results["follow"] = run(argv, follow_then(arm, [(POSE_B, 2)]))
        results["follow_torque"], results["follow_goals"] = arm.torque(), arm.goals_written
    results["follow_report"] = json.loads((out / "f" / "mirror_report.json").read_text())
    results["follow_csv"] = (out / "f" / "mirror_recording.csv").read_text()
    teleop = [
        *("--set", "simulation.mirror.apply=ACTUATOR"),
        *("--set", "simulation.mirror.record.lerobot=true", "--set", f"simulation.mirror.record.fps={TELEOP_FPS}"),
        *("--set", "simulation.render_width=64", "--set", "simulation.render_height=48"),
        *("--set", f"simulation.output_dir={out}/t"),
    ]
    with calibrated_arm(dict(POSE_A)) as leader:
        argv = [*MIRROR, *arm_sets("so101_leader", leader.port, good), *teleop]
        results["teleop"] = run(argv, follow_then(leader, [(POSE_A, 2), (POSE_B, TELEOP_PERIODS)]))
    results["teleop_report"] = json.loads((out / "t" / "mirror_report.json").read_text())
    results["dataset"] = load_dataset(out / "t" / "mirror_lerobot")
    missing = out / "missing.json"
    results["bad_port"] = run([*MIRROR, *arm_sets("so101_follower", str(out / "ttyACM9"), good)])
    with calibrated_arm() as arm:
        results["no_calibration"] = run([*MIRROR, *arm_sets("so101_follower", arm.port, missing)])
        arm.muted.set()
        results["silent"] = run([*MIRROR, *arm_sets("so101_follower", arm.port, good)])
    return results


def load_dataset(root: Path) -> dict[str, Any]:
    """The dataset at `root` as lerobot's own LeRobotDataset reads it: robot type, joint names, cameras, and every
    frame's state and action from its table (decoding the video, which joshua-lerobot's tests do for the same
    writer, would import torchcodec for seconds)."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    dataset = LeRobotDataset("local/joshua_teleop", root=root)
    table = dataset.hf_dataset
    return {
        "robot_type": dataset.meta.robot_type,
        "names": dataset.meta.features["action"]["names"],
        "frames": len(dataset),
        "cameras": dataset.meta.video_keys,
        "state": [state.tolist() for state in table["observation.state"]],
        "action": [action.tolist() for action in table["action"]],
    }


if __name__ == "__main__":
    group, folder = sys.argv[1], Path(sys.argv[2])
    scenarios = {"deploy": deploy_scenarios, "mirror": mirror_scenarios}[group]
    print(json.dumps({group: scenarios(folder)}))
