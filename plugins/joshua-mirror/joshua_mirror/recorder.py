"""What the mirror records: each mirrored joint's value (encoder + offset) and its command, sampled at a
fixed rate on a thread of its own, written at the end as a trajectory CSV (and, through joshua-lerobot, as a
LeRobot dataset). The sampling thread is its own so that the recording keeps its rate whatever the main loop
does (rendering a frame of the display takes longer than a sample period). Values and commands arrive on the
transport's thread; a float store is atomic in Python.

A teleoperation (a LeRobot leader driving the simulated arm) records what a LeRobot dataset of a real arm holds:
the state is the simulated arm's joint positions, the action the leader's values (+ offset), the targets its
actuators were given. A LeRobot arm's dataset is written in that arm's units (its calibration, `use_degrees`, the
mappings' offsets), so its values are the arm's own."""

from __future__ import annotations

import importlib.util
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from joshua_core.config_pb2 import SimulationConfig
from joshua_core.errors import ConfigError
from joshua_core.interfaces import render_size
from joshua_core.run_context import RunContext
from joshua_core.trajectory import Trajectory, write_trajectory
from joshua_mirror.joints import MirroredJoint, topic_mappings
from joshua_mirror.mirror import Mirror
from joshua_mirror.options_pb2 import MirrorRecording
from joshua_mirror.transport import RobotUnits

CSV_NAME = "mirror_recording.csv"
LEROBOT_NAME = "mirror_lerobot"
DEFAULT_FPS = 30
DEFAULT_TASK = "mirror"


class Recorder:
    """Samples the mirror's joint values and the latest commands (`teleop`: the simulated joints' positions and the
    leader's values); `period` seconds apart. `units`: what the arm's values are in, and the dataset's."""

    def __init__(
        self, joints: list[MirroredJoint], options: MirrorRecording, *, units: RobotUnits, teleop: bool = False
    ) -> None:
        if options.lerobot and importlib.util.find_spec("joshua_lerobot") is None:
            raise ConfigError(
                "simulation.mirror.record.lerobot needs joshua-lerobot: pip install -e plugins/joshua-lerobot"
            )
        if options.fps < 0:
            raise ConfigError(f"simulation.mirror.record.fps must be positive, got {options.fps}")
        self.joints = joints
        self.options = options
        self.units = units
        self.teleop = teleop
        self.fps = options.fps or DEFAULT_FPS
        self.period = 1.0 / self.fps
        self.commands = np.full(len(joints), np.nan)
        self.rows: list[list[float]] = []
        self.started_at: float | None = None

    @contextmanager
    def sampling(self, mirror: Mirror) -> Iterator[None]:
        """Sample `mirror` every `period` seconds on a thread of its own while the block runs; the rows are
        complete when it ends."""
        stop = threading.Event()
        thread = threading.Thread(target=self._sample_until, args=(mirror, stop), name="joshua-mirror-record")
        thread.start()
        try:
            yield
        finally:
            stop.set()
            thread.join()

    def _sample_until(self, mirror: Mirror, stop: threading.Event) -> None:
        next_sample = time.monotonic()
        while not stop.wait(max(0.0, next_sample - time.monotonic())):
            now = time.monotonic()
            self.sample(mirror, now)
            next_sample += self.period
            if next_sample <= now:  # woken late: carry on from now, no burst of samples
                next_sample = now + self.period

    def command_callback(self, index: int) -> Callable[[Any], None]:
        """The subscription callback storing joint `index`'s command (+ the joint's offset)."""
        offset = self.joints[index].offset

        def on_command(message: Any) -> None:
            self.commands[index] = message.data + offset

        return on_command

    def sample(self, mirror: Mirror, now: float) -> None:
        """Append a row of the current values, once every joint has one (before that there is nothing to record)."""
        values = [stats.last_value for stats in mirror.stats]
        if any(value is None for value in values):
            return
        if self.started_at is None:
            self.started_at = now
        values_sim = [joint.to_sim(value) for joint, value in zip(self.joints, values, strict=True)]
        if self.teleop:
            with mirror.lock:
                positions = [float(mirror.data.qpos[joint.qpos_address]) for joint in self.joints]
            self.rows.append([now - self.started_at, *positions, *values_sim])
        else:
            self.rows.append([now - self.started_at, *values_sim, *self.commands.tolist()])

    def write(self, config: SimulationConfig, context: RunContext) -> dict[str, Any]:
        """Write the CSV (and the LeRobot dataset); what was written, for the report."""
        if len(self.rows) < 2:
            return {"rows": len(self.rows), "csv": None, "lerobot": None}
        table = np.array(self.rows)
        count = len(self.joints)
        trajectory = Trajectory(
            path=context.output_dir / CSV_NAME,
            joint_names=tuple(joint.joint for joint in self.joints),
            timestamps=table[:, 0],
            positions=table[:, 1 : 1 + count],
            lines=np.arange(len(table)),
            targets=table[:, 1 + count :] if self.teleop or any(joint.command_topic for joint in self.joints) else None,
        )
        write_trajectory(trajectory.path, trajectory, comment=f"recorded by the MIRROR mode from {config.model_path}")
        written: dict[str, Any] = {"rows": len(table), "csv": str(trajectory.path), "lerobot": None}
        if self.options.lerobot:
            from joshua_lerobot import export_trajectory

            arm_units: dict[str, Any] = {}
            if self.units.lerobot is not None:  # the arm's own values, as lerobot-record would write them
                arm_units = {"units": self.units.lerobot, "mappings": list(topic_mappings(config))}
            written["lerobot"] = str(
                export_trajectory(
                    trajectory.path,
                    Path(config.model_path),
                    context.output_dir / LEROBOT_NAME,
                    fps=self.fps,
                    cameras=list(self.options.cameras) or [""],
                    size=render_size(config),
                    task=self.options.task or DEFAULT_TASK,
                    plugins=context.plugins,
                    overwrite=True,  # the recording of an earlier run into this output_dir, as the CSV beside
                    option="simulation.output_dir",
                    **arm_units,
                )
            )
        return written
