"""`joshua deploy POLICY_DIR`: run an exported policy (joshua-export) on a robot over ROS 2 or through LeRobot.

The MIRROR config says how the robot talks: its encoder topics (Float64 per joint or one JointState) with
each joint's offset, and `simulation.mirror.command_topics`, where each actuator's target goes (Float64, in
encoder units). With `--lerobot so10x_follower --port PORT --calibration JSON` the arm is reached through
lerobot's robot API instead (`LeRobotArm`), and the config gives only the joints and their offsets. The
policy's contract says the rest: task, robot model, observation terms, action mapping, control rate. Everything
is checked before the loop starts; bad input is one line, exit 2. Either way the same loop (`DeployLoop`) runs
the same safety.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import numpy as np

from joshua_core.atomic import atomic_write_json, json_safe
from joshua_core.cli import add_config_arguments, load, writable_folder
from joshua_core.config import finalize
from joshua_core.defaults import DEFAULT_OUTPUT_DIR, simulation_mode
from joshua_core.errors import ConfigError, PluginNotFoundError, UsageError
from joshua_core.interfaces import Command
from joshua_core.limits import MAX_CONTROL_HZ, MIN_CONTROL_HZ, cli_number
from joshua_core.options import options_of
from joshua_core.plugins import PluginHost
from joshua_core.runs import check_run_name, create_run
from joshua_mirror import options_pb2
from joshua_mirror.controller import COMMAND, PolicyController, unmapped_joints
from joshua_mirror.deploy_loop import DeployLoop
from joshua_mirror.joints import MirroredJoint, resolve_joints, topic_mappings
from joshua_mirror.lerobot_arm import ESTOP_SIGNAL, FOLLOWERS, LeRobotArm, lerobot_units
from joshua_mirror.link import RobotLink, RosTransport
from joshua_mirror.names import topic_argument
from joshua_mirror.options_pb2 import MirrorOptions
from joshua_mirror.ros import RosSession
from joshua_mirror.transport import ArmTransport, RobotUnits

DEFAULT_PRESET = "sim_mirror"
LEROBOT_PRESETS = {"so100_follower": "sim_mirror", "so101_follower": "so101_sim_mirror"}  # the arm's joints
UNITS = ("radians", "degrees", "range")  # the robot's: the model's own, or LeRobot's two (joshua_lerobot.BodyUnits)
DEFAULT_STALE_AFTER_S = 0.2
# rad/s (m/s for a slide joint): under the SO-ARM100 servos' top speed (STS3215: 0.222 s/60 deg at 7.4 V, 4.7 rad/s);
# a target that moves beyond the speed the servo can follow only builds up error
DEFAULT_MAX_SPEED = 4.0
DEFAULT_ESTOP_TOPIC = "/joshua_deploy/estop"
NODE_NAME = "joshua_deploy"
RUN_STEM = "deploy"
REPORT_FILE = "deploy_report.json"
MAX_TARGET_M = 1000.0  # metres from the model's origin: farther is no target a robot in the scene can reach


class DeployCommand(Command):
    """Runs an exported policy on a robot, as a ROS 2 node or through LeRobot: joint values in, joint targets out,
    at the contract's rate."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("policy", type=Path, help="folder with policy.onnx and policy.json (joshua export)")
        add_config_arguments(parser, verb=f"read the robot's topics (default: preset {DEFAULT_PRESET}) from")
        parser.add_argument(
            "--lerobot",
            choices=FOLLOWERS,
            metavar="ROBOT",
            help=f"drive the arm through lerobot's robot API ({', '.join(FOLLOWERS)}) instead of ROS 2; needs "
            f"--port and --calibration; e-stop: kill -{ESTOP_SIGNAL.name.removeprefix('SIG')} PID",
        )
        parser.add_argument("--port", metavar="DEVICE", help="the arm's serial port with --lerobot (/dev/ttyACM0)")
        parser.add_argument("--target", metavar="X,Y,Z", help="the task's target command, in model coordinates (m)")
        parser.add_argument(
            "--target-topic",
            type=topic_argument("--target-topic"),
            metavar="TOPIC",
            help="geometry_msgs/Point topic setting the target",
        )
        parser.add_argument(
            "--rate",
            type=cli_number("--rate", MIN_CONTROL_HZ, MAX_CONTROL_HZ),
            metavar="HZ",
            help="control rate (default: the contract's)",
        )
        parser.add_argument(
            "--stale-after",
            type=float,
            default=DEFAULT_STALE_AFTER_S,
            metavar="S",
            help=f"hold when a joint's value is older (default {DEFAULT_STALE_AFTER_S:g} s)",
        )
        parser.add_argument(
            "--max-speed",
            type=float,
            default=DEFAULT_MAX_SPEED,
            metavar="RAD_PER_S",
            help=f"fastest a target may move (default {DEFAULT_MAX_SPEED:g} rad/s)",
        )
        parser.add_argument(
            "--estop-topic",
            type=topic_argument("--estop-topic"),
            help=f"std_msgs/Bool; true stops the arm in place until restart (default {DEFAULT_ESTOP_TOPIC})",
        )
        parser.add_argument(
            "--units",
            choices=UNITS,
            help="the robot's units on the encoder and command topics: radians (default over ROS), or LeRobot's "
            "for an SO-10x driven by its follower: degrees (use_degrees=True, the default with --lerobot) or range "
            "(use_degrees=False, needs --calibration); needs joshua-lerobot",
        )
        parser.add_argument(
            "--calibration", type=Path, metavar="JSON", help="the arm's LeRobot calibration file (lerobot-calibrate)"
        )
        parser.add_argument("--duration", type=float, default=0.0, metavar="S", help="stop after S s (0: Ctrl-C)")
        parser.add_argument("--status-period", type=float, default=1.0, metavar="S", help="seconds between statuses")
        parser.add_argument("--output-dir", default=DEFAULT_OUTPUT_DIR, help="where the run folder goes")
        parser.add_argument("--run-name", help=f"the run folder's name (default {RUN_STEM}_<date>-<time>)")

    def run(self, args: argparse.Namespace, plugins: PluginHost) -> int:
        if args.run_name is not None:
            check_run_name(args.run_name, "--run-name")
        target = _parse_target(args.target)
        _check_transport(args)
        if target is None and not args.target_topic:
            raise UsageError("give the policy a target: --target X,Y,Z and/or --target-topic TOPIC")
        for name in ("stale_after", "max_speed", "status_period"):
            _check_positive(f"--{name.replace('_', '-')}", getattr(args, name))
        if not math.isfinite(args.duration) or args.duration < 0:
            raise UsageError(f"--duration must be 0 or more seconds (got {args.duration:g})")
        if not args.preset and not args.config:
            args.preset = LEROBOT_PRESETS[args.lerobot] if args.lerobot else DEFAULT_PRESET
        config = finalize(load(args, plugins.options())).simulation
        if simulation_mode(config) != "MIRROR":
            mode = simulation_mode(config)
            raise ConfigError(f"joshua deploy reads the robot's topics from a MIRROR config; this one is {mode}")
        policy, contract, observer = _load(args.policy, plugins)
        rate = contract["control_hz"] if args.rate is None else args.rate
        options = options_of(config, options_pb2.mirror)
        joints, commanded = _robot_joints(observer, contract, config, options, by_topics=not args.lerobot)
        units = _robot_units(args.units or ("degrees" if args.lerobot else UNITS[0]), args.calibration, joints)
        _check_arm(args.lerobot, units)
        controller = PolicyController(policy, contract, observer, joints, args.max_speed / rate)
        root = writable_folder(args.output_dir, "--output-dir")
        if args.run_name and (root / args.run_name).exists():
            raise UsageError(f"run folder {root / args.run_name} exists; choose another --run-name")
        with create_run(root, args.run_name, stem=RUN_STEM, options="--run-name") as run, ExitStack() as stack:
            transport = _open_transport(stack, args, joints, options, commanded, units, rate)
            link = RobotLink(transport, commanded)
            loop = DeployLoop(
                link,
                controller,
                rate=rate,
                stale_after=args.stale_after,
                status_period=args.status_period,
                fixed_target=target,
            )
            estop = f"kill -{ESTOP_SIGNAL.name.removeprefix('SIG')} {os.getpid()}" if args.lerobot else args.estop_topic
            print(
                f"joshua: deploy: {args.policy} ({contract['task']}) on {len(joints)} joints at {rate:g} Hz; "
                f"e-stop: {estop}",
                file=sys.stderr,
                flush=True,
            )
            stopped_by = loop.run(args.duration)
            transport.close()  # nothing changes the counts while they are reported
            report = _report(args, contract, rate, loop, link, stopped_by)
            path = run.path / REPORT_FILE
            atomic_write_json(path, json_safe(report))
        estop = "latched" if link.estop_at else "no"
        print(
            f"deployed {contract['task']} for {loop.wall_seconds:.1f} s ({stopped_by}): {loop.stats.steps} steps, "
            f"{loop.stats.hold_episodes} holds, e-stop {estop}; report: {path}"
        )
        problem = transport.error()
        if problem:
            raise ConfigError(problem)
        return 0


def _check_transport(args: argparse.Namespace) -> None:
    """The options of one transport only: --port with --lerobot, the topics without it."""
    if args.lerobot:
        given = [name for name in ("target_topic", "estop_topic") if getattr(args, name)]
        if given:
            option = "--" + given[0].replace("_", "-")
            raise UsageError(f"{option} is a ROS 2 topic; with --lerobot give --target, stop with Ctrl-C or SIGUSR1")
        if not args.port:
            raise UsageError("--lerobot needs the arm's serial port: --port /dev/ttyACM0 (lerobot-find-port)")
        if args.calibration is None:
            raise UsageError("--lerobot needs the arm's calibration: --calibration JSON (what lerobot-calibrate wrote)")
    elif args.port:
        raise UsageError("--port is the serial port of a LeRobot arm: give --lerobot with it")
    args.estop_topic = args.estop_topic or DEFAULT_ESTOP_TOPIC


def _check_arm(robot_type: str | None, units: RobotUnits) -> None:
    """A LeRobot follower drives the arm of the policy's model: SO-ARM100 joints for so100, SO-101's for so101."""
    if robot_type is None:
        return
    if units.robot_type != robot_type:
        raise UsageError(f"--lerobot {robot_type} is another arm than the policy's model ({units.robot_type})")


def _open_transport(
    stack: ExitStack,
    args: argparse.Namespace,
    joints: list[MirroredJoint],
    options: MirrorOptions,
    commanded: list[MirroredJoint],
    units: RobotUnits,
    rate: float,
) -> ArmTransport:
    """The arm's transport for this run, closed when `stack` closes: a LeRobot robot or a ROS 2 node."""
    if args.lerobot:
        arm = LeRobotArm(args.lerobot, args.port, args.calibration, units, joints, period=0.5 / rate, estop_signal=True)
        return stack.enter_context(arm)
    ros = stack.enter_context(RosSession(NODE_NAME))
    return RosTransport(ros, joints, options, commanded, args.estop_topic, args.target_topic, units)


def _load(folder: Path, plugins: PluginHost) -> tuple[Any, dict[str, Any], Any]:
    """The policy, its contract and the task's observer on the contract's model (joshua-export's loader)."""
    try:
        from joshua_export import contract_observer, load_policy
    except ImportError:
        raise PluginNotFoundError(
            "joshua deploy runs policies exported by joshua-export, which is not installed: "
            "pip install -e plugins/joshua-export (or ./setup.sh --all)"
        ) from None
    try:
        policy, contract = load_policy(folder)
        observer = contract_observer(contract, plugins)
        commands = dict(contract["observation"]["commands"])
        actuators = [term["actuator"] for term in contract["action"]["terms"]]
    except UsageError:
        raise
    except (KeyError, TypeError, ValueError) as error:
        raise UsageError(f"{folder / 'policy.json'}: malformed contract (missing or wrong {error})") from None
    if not actuators:
        raise UsageError(f"{folder / 'policy.json'}: the policy drives no actuator")
    if commands != {COMMAND: 3}:
        raise UsageError(
            f"the policy of task '{contract['task']}' needs the commands {commands}; joshua deploy gives a policy "
            f"only a '{COMMAND}' of 3 values (--target, --target-topic)"
        )
    return policy, contract, observer


def _robot_units(name: str, calibration: Path | None, joints: list[MirroredJoint]) -> RobotUnits:
    """The robot's units `name` (--units) for the mirrored `joints`: radians, or LeRobot's (`lerobot_units`)."""
    if name == UNITS[0]:
        if calibration is not None:
            raise UsageError("--calibration is for LeRobot's units: give --units degrees or range with it")
        return RobotUnits()
    return lerobot_units(name, calibration, joints, option=f"--units {name}")


def _robot_joints(
    observer: Any, contract: dict[str, Any], config: Any, options: MirrorOptions, *, by_topics: bool
) -> tuple[list[MirroredJoint], list[MirroredJoint]]:
    """The mapped joints (checked against the policy's model: all its joints measured, position actuators) and,
    in the contract's action order, those the policy drives, each with its command topic when `by_topics`."""
    checked = MirrorOptions()
    checked.CopyFrom(options)
    checked.apply = MirrorOptions.ACTUATOR  # targets are joint positions: only position actuators take them
    joints = resolve_joints(observer.model, topic_mappings(config), checked, by_topics=by_topics)
    missing = unmapped_joints(observer.model, joints)
    if missing:
        raise ConfigError(
            f"the policy observes joints that the mirror config does not map: {', '.join(missing)} "
            "(add them to simulation.mirror_topic_mappings)"
        )
    by_actuator = {joint.actuator: joint for joint in joints}
    actuators = [term["actuator"] for term in contract["action"]["terms"]]
    for problem, names in (
        ("a mapping (simulation.mirror_topic_mappings)", [name for name in actuators if name not in by_actuator]),
        ("a command topic (simulation.mirror.command_topics)",
         [name for name in actuators if by_topics and name in by_actuator and not by_actuator[name].command_topic]),
    ):  # fmt: skip
        if names:
            raise ConfigError(f"the policy drives actuators without {problem}: {', '.join(names)}")
    return joints, [by_actuator[name] for name in actuators]


def _parse_target(text: str | None) -> np.ndarray | None:
    if text is None:
        return None
    try:
        values = np.array([float(part) for part in text.split(",")])
    except ValueError:
        values = np.array([])
    if values.shape != (3,) or not (np.abs(values) <= MAX_TARGET_M).all():  # NaN fails too
        raise UsageError(f"--target takes three numbers X,Y,Z in metres within ±{MAX_TARGET_M:g} (got '{text}')")
    return values


def _check_positive(option: str, value: float) -> None:
    if not (0 < value < math.inf):  # also refuses NaN
        raise UsageError(f"{option} must be a finite positive number (got {value:g})")


def _report(
    args: argparse.Namespace,
    contract: dict[str, Any],
    rate: float,
    loop: DeployLoop,
    link: RobotLink,
    stopped_by: str,
) -> dict[str, Any]:
    """deploy_report.json: the settings, what the loop did, and per joint what came in and went out."""
    controller = loop.controller
    driven = {entry.joint.joint: entry for entry in controller.actuated}
    last = controller.last_targets
    joints = {}
    for index, joint in enumerate(link.joints):
        entry = driven.get(joint.joint)
        position = list(driven).index(joint.joint) if entry else None
        joints[joint.joint] = {
            "source": joint.source,
            "offset": joint.offset,
            "received": int(link.received[index]),
            "rejected_non_finite": int(link.rejected[index]),
            "last_value": float(link.values[index]),
            "command_topic": joint.command_topic or None,
            "last_target_sent": None
            if last is None or position is None
            else link.transport.units.from_radians(joint, float(last[position]) - joint.offset),
            "limited": entry.limited if entry else 0,
            "slowed": entry.slowed if entry else 0,
        }
    target = loop.target()
    return {
        "policy": str(args.policy),
        "task": contract["task"],
        "trainer": contract["trainer"],
        "config": str(args.config) if args.config else f"preset {args.preset}",
        "rate_hz": rate,
        "stale_after_s": args.stale_after,
        "max_speed": args.max_speed,
        **link.transport.report(),
        "target": None if target is None else [float(value) for value in target],
        "targets_received": link.targets_received,
        "stopped_by": stopped_by,
        "wall_seconds": loop.wall_seconds,
        **loop.stats.report(),
        "joints": joints,
    }
