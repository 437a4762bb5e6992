"""`joshua mirror-replay CSV`: play a recorded trajectory as a robot's encoder topics, in real time.

The config (a MIRROR preset or file) says which topics to publish and with which offsets; each value
published is CSV value - offset, so that the mirror (which adds the offset back) shows the CSV's
joint positions. It publishes std_msgs/Float64 per topic, or one sensor_msgs/JointState topic when
the config's message_type is JOINT_STATE or with --joint-state.
"""

from __future__ import annotations

import argparse
import difflib
import sys
import time
from pathlib import Path

import numpy as np

from joshua_core.cli import add_config_arguments, load
from joshua_core.config import finalize
from joshua_core.config_pb2 import SimulationConfig
from joshua_core.defaults import simulation_mode
from joshua_core.errors import ConfigError, UsageError
from joshua_core.interfaces import Command
from joshua_core.limits import MAX_CONTROL_HZ, MAX_REPLAY_SPEED, MAX_WAIT_S, cli_number
from joshua_core.options import options_of
from joshua_core.plugins import PluginHost
from joshua_core.progress import progress_bar
from joshua_core.resources import resolve_data_path
from joshua_core.trajectory import Trajectory, read_trajectory
from joshua_mirror import options_pb2
from joshua_mirror.joints import MirroredJoint, resolve_joints, topic_mappings
from joshua_mirror.mode import DEFAULT_JOINT_STATE_TOPIC
from joshua_mirror.options_pb2 import MirrorOptions
from joshua_mirror.ros import RosSession, message_types

DEFAULT_PRESET = "sim_mirror"
DEFAULT_RATE_HZ = 100.0
MAX_LOOPS = 1_000_000  # plays of one trajectory: more is a typo, not a session
SUBSCRIBER_WAIT_POLL_S = 0.02
# After our side sees the subscriber, its side still needs a moment to match us; samples sent before are lost.
MATCH_SETTLE_S = 0.5


class MirrorReplayCommand(Command):
    """Publishes a trajectory CSV on the encoder topics of a MIRROR config."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("csv", type=Path, help="trajectory CSV: '#' comments, header 'timestamp,<joint names>'")
        add_config_arguments(parser, verb=f"read the topics and offsets (default: preset {DEFAULT_PRESET}) from")
        parser.add_argument(
            "--rate",
            type=cli_number("--rate", 0, MAX_CONTROL_HZ, above=True),
            default=DEFAULT_RATE_HZ,
            help=f"messages per second per topic, interpolated from the CSV (default {DEFAULT_RATE_HZ:g})",
        )
        parser.add_argument(
            "--speed",
            type=cli_number("--speed", 0, MAX_REPLAY_SPEED, above=True),
            default=1.0,
            help="playback speed factor (default 1: real time)",
        )
        parser.add_argument(
            "--loops",
            type=cli_number("--loops", 1, MAX_LOOPS, integer=True),
            default=1,
            help="play the trajectory this many times (default 1)",
        )
        parser.add_argument(
            "--joint-state",
            action="store_true",
            help="publish sensor_msgs/JointState whatever the config's message_type says",
        )
        parser.add_argument(
            "--wait",
            type=cli_number("--wait", 0, MAX_WAIT_S),
            default=10.0,
            metavar="S",
            help="seconds to wait for the mirror to subscribe before playing (default 10)",
        )

    def run(self, args: argparse.Namespace, plugins: PluginHost) -> int:
        if not args.preset and not args.config:
            args.preset = DEFAULT_PRESET
        config = finalize(load(args, plugins.options())).simulation
        if simulation_mode(config) != "MIRROR":
            raise ConfigError(f"mirror-replay needs a MIRROR config; this one is {simulation_mode(config)}")
        options = options_of(config, options_pb2.mirror)
        if args.joint_state:
            options.message_type = MirrorOptions.JOINT_STATE
        joints, model_joints = _joints_of(config, options, plugins)
        trajectory = read_trajectory(resolve_data_path(args.csv, what="trajectory"), model_joints)
        trajectory.require_playable()
        columns = _columns(trajectory, joints, args.csv)
        times = np.arange(trajectory.timestamps[0], trajectory.timestamps[-1] + 1e-9, 1.0 / args.rate)
        encoder_values = np.stack(
            [
                np.interp(times, trajectory.timestamps, trajectory.positions[:, column]) - joint.offset
                for joint, column in zip(joints, columns, strict=True)
            ],
            axis=1,
        )
        commanded = _commanded(trajectory, joints, columns)
        encoder_values = np.hstack(
            [encoder_values, *(_interp_target(trajectory, times, column, joint) for joint, column in commanded)]
        )
        with RosSession("joshua_mirror_replay") as ros:
            publisher = _EncoderPublisher(ros, options, joints, [joint.command_topic for joint, _ in commanded])
            publisher.wait_for_subscribers(args.wait)
            try:
                _play(publisher, times - times[0], encoder_values, args.speed, args.loops)
            except KeyboardInterrupt:
                print("joshua: mirror-replay: stopped", file=sys.stderr)
                return 130
        print(f"published {len(times) * args.loops} samples of {len(joints)} joints from {args.csv}")
        return 0


def _joints_of(
    config: SimulationConfig, options: MirrorOptions, plugins: PluginHost
) -> tuple[list[MirroredJoint], list[str]]:
    """The config's mapped joints (checked against its model as its mirror `options` say, like the mirror does), and
    the model's hinge and slide joints: the columns a trajectory of this model may have (the rule of every trajectory
    reader). The model is the engine's of the backend the config names, as the mirror's is."""
    import mujoco

    with plugins.backend(config.backend).create_engine(Path(config.model_path), plugins) as engine:
        model = engine.model
        scalar = {int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)}
        names = [model.joint(j).name for j in range(model.njnt) if int(model.jnt_type[j]) in scalar]
        return resolve_joints(model, topic_mappings(config), options), names


def _columns(trajectory: Trajectory, joints: list[MirroredJoint], csv: Path) -> list[int]:
    """The CSV column of each mapped joint (by the name of the MuJoCo joint it drives)."""
    missing = [joint.joint for joint in joints if joint.joint not in trajectory.joint_names]
    if missing:
        hints = []
        for name in missing:
            close = difflib.get_close_matches(name, trajectory.joint_names, n=1)
            hints.append(f"{name} (did you mean {close[0]}?)" if close else name)
        raise UsageError(
            f"{csv}: no column for the mapped joints {', '.join(hints)}; columns: {', '.join(trajectory.joint_names)}"
        )
    return [trajectory.joint_names.index(joint.joint) for joint in joints]


def _commanded(
    trajectory: Trajectory, joints: list[MirroredJoint], columns: list[int]
) -> list[tuple[MirroredJoint, int]]:
    """The mapped joints with a command topic whose CSV column has targets (`<joint>.target`)."""
    if trajectory.targets is None:
        return []
    return [
        (joint, column)
        for joint, column in zip(joints, columns, strict=True)
        if joint.command_topic and np.isfinite(trajectory.targets[:, column]).any()
    ]


def _interp_target(trajectory: Trajectory, times: np.ndarray, column: int, joint: MirroredJoint) -> np.ndarray:
    """One joint's targets at `times` in encoder units (the offset taken off, as for positions): a (times, 1) column."""
    assert trajectory.targets is not None
    known = np.isfinite(trajectory.targets[:, column])
    values = np.interp(times, trajectory.timestamps[known], trajectory.targets[known, column]) - joint.offset
    return values[:, None]


class _EncoderPublisher:
    """Publishes one row of encoder values the way a mirror of these `options` listens: Float64 per topic or
    JointState, then the row's commands (its last values), Float64 on each of `command_topics`."""

    def __init__(
        self, ros: RosSession, options: MirrorOptions, joints: list[MirroredJoint], command_topics: list[str]
    ) -> None:
        float64, joint_state = message_types()
        self.node = ros.node
        self.float64 = float64
        self.joint_state = joint_state
        if options.message_type == MirrorOptions.JOINT_STATE:
            topic = options.joint_state_topic or DEFAULT_JOINT_STATE_TOPIC
            self.publishers = [self.node.create_publisher(joint_state, topic, 10)]
            self.names: list[str] | None = [joint.source for joint in joints]
        else:
            self.publishers = [self.node.create_publisher(float64, joint.source, 10) for joint in joints]
            self.names = None
        self.encoders = len(self.publishers)  # the mirror always listens to these; to commands only when recording
        self.publishers += [self.node.create_publisher(float64, topic, 10) for topic in command_topics]

    def publish(self, row: np.ndarray) -> None:
        values = row.tolist()
        if self.names is None:
            for publisher, value in zip(self.publishers, values, strict=True):
                publisher.publish(self.float64(data=value))
            return
        message = self.joint_state(name=self.names, position=values[: len(self.names)])
        message.header.stamp = self.node.get_clock().now().to_msg()
        self.publishers[0].publish(message)
        for publisher, value in zip(self.publishers[1:], values[len(self.names) :], strict=True):
            publisher.publish(self.float64(data=value))

    def wait_for_subscribers(self, timeout: float) -> None:
        """Wait until every encoder topic has a subscriber (the mirror), so the start of the trajectory is not lost."""
        deadline = time.monotonic() + timeout
        while not all(publisher.get_subscription_count() for publisher in self.publishers[: self.encoders]):
            if time.monotonic() > deadline:
                print(
                    f"joshua: mirror-replay: no mirror subscribed within {timeout:g} s; publishing anyway",
                    file=sys.stderr,
                )
                return
            time.sleep(SUBSCRIBER_WAIT_POLL_S)
        time.sleep(MATCH_SETTLE_S)


def _play(publisher: _EncoderPublisher, offsets_s: np.ndarray, values: np.ndarray, speed: float, loops: int) -> None:
    """Publish row k at start + offsets_s[k] / speed (each loop starts one sample after the last), with progress."""
    duration = float(offsets_s[-1])
    period = duration / (len(offsets_s) - 1) if len(offsets_s) > 1 else 0.0
    with progress_bar(duration * loops, description="mirror-replay", unit="s") as bar:
        for loop in range(loops):
            start = time.monotonic()
            done = 0.0
            for offset, row in zip(offsets_s, values, strict=True):
                delay = start + offset / speed - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
                publisher.publish(row)
                bar.update(float(offset) - done)
                done = float(offset)
            if loop + 1 < loops:
                time.sleep(period / speed)
