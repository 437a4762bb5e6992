"""`joshua deploy POLICY_DIR`: run an exported policy (joshua-export) on a robot over ROS 2.

The MIRROR config says how the robot talks: its encoder topics (Float64 per joint or one JointState) with
each joint's offset, and `simulation.mirror.command_topics`, where each actuator's target goes (Float64, in
encoder units). The policy's contract says the rest: task, robot model, observation terms, action mapping,
control rate. Everything is checked before the node starts; bad input is one line, exit 2.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import sys
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
from joshua_mirror.graph import TypeChecker
from joshua_mirror.joints import MirroredJoint, resolve_joints
from joshua_mirror.link import RobotLink, RobotUnits
from joshua_mirror.names import topic_argument
from joshua_mirror.options_pb2 import MirrorOptions
from joshua_mirror.ros import RosSession

DEFAULT_PRESET = "sim_mirror"
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
    """Runs an exported policy as a ROS 2 node: encoders in, joint targets out, at the contract's rate."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("policy", type=Path, help="folder with policy.onnx and policy.json (joshua export)")
        add_config_arguments(parser, verb=f"read the robot's topics (default: preset {DEFAULT_PRESET}) from")
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
            default=DEFAULT_ESTOP_TOPIC,
            help=f"std_msgs/Bool; true stops the arm in place until restart (default {DEFAULT_ESTOP_TOPIC})",
        )
        parser.add_argument(
            "--units",
            choices=UNITS,
            default=UNITS[0],
            help="the robot's units on the encoder and command topics: radians (default), or LeRobot's for an "
            "SO-100 driven by its follower: degrees (use_degrees=True) or range (use_degrees=False, needs "
            "--calibration); needs joshua-lerobot",
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
        if target is None and not args.target_topic:
            raise UsageError("give the policy a target: --target X,Y,Z and/or --target-topic TOPIC")
        for name in ("stale_after", "max_speed", "status_period"):
            _check_positive(f"--{name.replace('_', '-')}", getattr(args, name))
        if not math.isfinite(args.duration) or args.duration < 0:
            raise UsageError(f"--duration must be 0 or more seconds (got {args.duration:g})")
        if not args.preset and not args.config:
            args.preset = DEFAULT_PRESET
        config = finalize(load(args, plugins.options())).simulation
        if simulation_mode(config) != "MIRROR":
            mode = simulation_mode(config)
            raise ConfigError(f"joshua deploy reads the robot's topics from a MIRROR config; this one is {mode}")
        policy, contract, observer = _load(args.policy, plugins)
        rate = contract["control_hz"] if args.rate is None else args.rate
        options = options_of(config, options_pb2.mirror)
        joints, commanded = _robot_joints(observer, contract, config, options)
        units = _robot_units(args.units, args.calibration, joints)
        controller = PolicyController(policy, contract, observer, joints, args.max_speed / rate)
        root = writable_folder(args.output_dir, "--output-dir")
        if args.run_name and (root / args.run_name).exists():
            raise UsageError(f"run folder {root / args.run_name} exists; choose another --run-name")
        with create_run(root, args.run_name, stem=RUN_STEM, options="--run-name") as run, RosSession(NODE_NAME) as ros:
            link = RobotLink(ros, joints, options, commanded, args.estop_topic, args.target_topic, units)
            types = TypeChecker(ros.node, link.expected_types, reader="deploy")
            loop = DeployLoop(
                link,
                controller,
                types,
                rate=rate,
                stale_after=args.stale_after,
                status_period=args.status_period,
                fixed_target=target,
            )
            print(
                f"joshua: deploy: {args.policy} ({contract['task']}) on {len(joints)} joints at {rate:g} Hz; "
                f"e-stop: {args.estop_topic}",
                file=sys.stderr,
                flush=True,
            )
            stopped_by = loop.run(args.duration)
            ros.close()  # no callback changes the counts while they are reported
            report = _report(args, contract, rate, loop, link, stopped_by, types)
            path = run.path / REPORT_FILE
            atomic_write_json(path, json_safe(report))
        estop = "latched" if link.estop_at else "no"
        print(
            f"deployed {contract['task']} for {loop.wall_seconds:.1f} s ({stopped_by}): {loop.stats.steps} steps, "
            f"{loop.stats.hold_episodes} holds, e-stop {estop}; report: {path}"
        )
        problem = types.error()
        if problem:
            raise ConfigError(problem)
        return 0


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
    """The robot's units `name` (--units) for the mirrored `joints`: LeRobot's need joshua-lerobot and the
    SO-ARM100's joints, each mapped to its SO-100 motor."""
    if name == UNITS[0]:
        if calibration is not None:
            raise UsageError("--calibration is for LeRobot's units: give --units degrees or range with it")
        return RobotUnits()
    if importlib.util.find_spec("joshua_lerobot") is None:
        raise PluginNotFoundError(f"--units {name} converts with joshua-lerobot: pip install joshua-lerobot")
    from joshua_lerobot import BodyUnits, LeRobotUnits, feature_names, read_calibration

    names, robot_type = feature_names([joint.joint for joint in joints])
    if robot_type is None:
        raise UsageError(f"--units {name} is for the SO-100's six joints; the config mirrors {len(joints)} others")
    lerobot = LeRobotUnits(BodyUnits(name), None if calibration is None else read_calibration(calibration))
    return RobotUnits(lerobot, {joint.joint: feature for joint, feature in zip(joints, names, strict=True)})


def _robot_joints(
    observer: Any, contract: dict[str, Any], config: Any, options: MirrorOptions
) -> tuple[list[MirroredJoint], list[MirroredJoint]]:
    """The mapped joints (checked against the policy's model: all its joints measured, position actuators) and,
    in the contract's action order, those the policy drives, each with its command topic."""
    checked = MirrorOptions()
    checked.CopyFrom(options)
    checked.apply = MirrorOptions.ACTUATOR  # targets are joint positions: only position actuators take them
    joints = resolve_joints(observer.model, config.mirror_topic_mappings.mappings, checked)
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
         [name for name in actuators if name in by_actuator and not by_actuator[name].command_topic]),
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
    types: TypeChecker,
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
            else link.robot_value(joint, float(last[position])),
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
        "estop_topic": args.estop_topic,
        "target_topic": args.target_topic,
        "target": None if target is None else [float(value) for value in target],
        "targets_received": link.targets_received,
        "stopped_by": stopped_by,
        "wall_seconds": loop.wall_seconds,
        **loop.stats.report(),
        "joints": joints,
        "type_mismatches": types.seen,
    }
