"""`joshua checklist RUN`: the arm-side checklist of one trained run, from simulation to the real arm.

For each step (model, system identification, domain randomization, latency and control rate, units and joint
limits, calibration, deploy) it says what JOSHUA checked in the run's files, with the result, and what the user
verifies on the arm, and how. It reads the run's config.json and metrics.json, builds the task on the run's model as
training did, checks the exported policy (joshua-export) against them when there is one, and, where installed,
reads the sysid fit of the model (joshua-sysid) and LeRobot's names and units (joshua-lerobot). The guide to the
same steps is docs/sim-to-real.md. Bad input is one line, exit 2; a problem found in the run's files exits 1.
"""

from __future__ import annotations

import argparse
import importlib.util
import textwrap
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from joshua_core.interfaces import Command
from joshua_core.plugins import PluginHost
from joshua_core.tasks import METRIC_PREFIX
from joshua_core.tasks.randomization import (
    CURRICULUM_METRIC,
    action_delay,
    observation_noise,
    push_body,
    randomize_actuator_gains,
    randomize_body_mass,
    randomize_camera_pose,
    randomize_geom_friction,
    randomize_geom_rgba,
    randomize_joint_armature,
    randomize_joint_damping,
    randomize_joint_offset,
    randomize_light,
)
from joshua_mirror.controller import COMMAND
from joshua_mirror.deploy import DEFAULT_MAX_SPEED, DEFAULT_STALE_AFTER_S, LEROBOT_PRESETS
from joshua_mirror.lerobot_arm import ESTOP_SIGNAL
from joshua_mirror.trained_run import Run, follower_type, read_run

OK, PROBLEM, YOU, TODO = "ok", "!!", "you", "--"
LEGEND = "[ok] JOSHUA checked it in the run's files  [!!] a problem  [you] verify it on your arm  [--] not done yet"
WIDTH = 110
PORT = "/dev/ttyACM0"  # lerobot-find-port names the real one
CALIBRATION_DIR = "~/.cache/huggingface/lerobot/calibration/robots/so_follower"  # where lerobot-calibrate writes
SLOW_SPEED = 0.5  # rad/s for the first run on the arm: slow enough to stop by hand
SLOW_DURATION_S = 10.0
# What each randomization event stands for on the real arm; the gaps no event covers are in UNCOVERED.
GAPS: tuple[tuple[str, tuple[Callable[..., Any], ...]], ...] = (
    ("friction", (randomize_geom_friction,)),
    ("masses and inertias", (randomize_body_mass,)),
    ("servo gains", (randomize_actuator_gains,)),
    ("joint damping", (randomize_joint_damping,)),
    ("armature", (randomize_joint_armature,)),
    ("servo zero offsets", (randomize_joint_offset,)),
    ("sensor noise", (observation_noise,)),
    ("latency", (action_delay,)),
    ("pushes", (push_body,)),
)
CAMERA_GAPS = (("colours, camera pose and light", (randomize_geom_rgba, randomize_camera_pose, randomize_light)),)
SYSID_GAPS = {"servo gains", "joint damping", "armature"}  # what a joshua sysid fit measures instead
UNCOVERED = "backlash and gear play, servo torque limits and supply voltage, cable drag, contact shapes"


@dataclass
class Checklist:
    """Sections of marked items, rendered as text; problems decide the exit status."""

    sections: list[tuple[str, list[tuple[str, str]]]] = field(default_factory=list)

    def section(self, title: str) -> list[tuple[str, str]]:
        items: list[tuple[str, str]] = []
        self.sections.append((title, items))
        return items

    def problems(self) -> int:
        return sum(mark == PROBLEM for _, items in self.sections for mark, _ in items)

    def render(self) -> str:
        lines = []
        for number, (title, items) in enumerate(self.sections, 1):
            lines.append(f"\n{number}. {title}")
            for mark, text in items:
                if mark == "":  # a command line or a table row: as it is
                    lines.append(f"       {text}")
                    continue
                head = f"  [{mark}]".ljust(8)
                lines.append(
                    textwrap.fill(text, WIDTH, initial_indent=head, subsequent_indent=" " * 8, break_on_hyphens=False)
                )
        return "\n".join(lines)


class ChecklistCommand(Command):
    """Prints the arm-side checklist of a trained run: per step what JOSHUA checked and what to verify on the arm."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("run", type=Path, help="run folder (its last checkpoint) or one checkpoint folder")
        parser.add_argument(
            "--policy", type=Path, metavar="DIR", help="the exported policy (default: the checkpoint folder's)"
        )
        parser.add_argument("--port", default=PORT, metavar="DEVICE", help=f"the arm's serial port (default {PORT})")
        parser.add_argument(
            "--calibration", type=Path, metavar="JSON", help="the arm's LeRobot calibration file, checked if given"
        )

    def run(self, args: argparse.Namespace, plugins: PluginHost) -> int:
        run = read_run(args, plugins)
        robot_type = follower_type(run)
        checklist = Checklist()
        _model(run, checklist.section("Model"))
        fit = _sysid(run, checklist.section("System identification"))
        _randomization(run, fit, checklist.section("Domain randomization"))
        _latency(run, checklist.section("Latency and control rate"))
        _units(run, robot_type, checklist.section("Units and joint limits"))
        calibration = _calibration(run, robot_type, args, checklist.section("Calibration"))
        _deploy(run, robot_type, args.port, calibration, checklist.section("Deploy: the commands to try, in order"))
        print(f"Arm-side checklist of run {run.given} (checkpoint {run.checkpoint})\n{LEGEND}\n{checklist.render()}")
        problems = checklist.problems()
        if problems:
            print(f"\n{problems} problem(s) marked [!!]: settle them before the arm moves")
        return 1 if problems else 0


def _model(run: Run, items: list[tuple[str, str]]) -> None:
    record = run.record or {}
    learned = ", ".join(
        f"{name} {record[key]:.4g}"
        for name, key in (("mean return", "mean_return"), ("success", f"{METRIC_PREFIX}success"))
        if isinstance(record.get(key), int | float)
    )
    steps = record.get("step")
    trained = f" for {steps:,} env steps" if isinstance(steps, int | float) else ""
    items.append(
        (
            OK,
            f"trained by {run.trainer} on task {run.training.task}{trained}"
            + (f"; last record: {learned}" if learned else ""),
        )
    )
    items.append(
        (
            OK,
            f"model {run.model_path} compiles and the task builds on it as in training: {run.model.nu} actuators, "
            f"an observation of {run.task.observation_size} values, commands {run.task.commands or 'none'}",
        )
    )
    if run.contract_problems:
        items.extend((PROBLEM, f"exported policy {run.policy_dir}: {problem}") for problem in run.contract_problems)
    elif run.contract is not None:
        items.append(
            (
                OK,
                f"exported policy {run.policy_dir}: the ONNX file matches its sha256, the compiled model and the "
                "observation terms match the run's (joshua deploy checks them again before anything moves)",
            )
        )
    else:
        items.append((TODO, f"not exported yet: joshua export {run.given}"))
    items.append(
        (
            YOU,
            "the twin is your arm: with command 1 below running (read only), move each joint by hand from one end to "
            "the other; the twin's joint must move the same way, through the same angles",
        )
    )


def _sysid(run: Run, items: list[tuple[str, str]]) -> Any:
    """The sysid fit of the run's model, or None."""
    if importlib.util.find_spec("joshua_sysid") is None:
        items.append((TODO, "joshua-sysid is not installed: nothing says whether the model's servos are the arm's"))
        return None
    from joshua_sysid import fit_of

    fit = fit_of(run.model_path)
    if fit is None:
        items.append(
            (
                TODO,
                f"{run.model_path.name} holds no joshua sysid fit: its servos are the nominal STS3215 values. Record "
                "the arm following multi-sine targets and fit: joshua sysid REC.csv --model ARM.xml; train on the "
                "calibrated model (training.model_path)",
            )
        )
        return None
    report = fit.report
    rms = report.get("tracking_rms", {})
    before, after = rms.get("overall_before"), rms.get("overall_after")
    tracked = (
        f": tracking RMS {before:.3g} -> {after:.3g} rad"
        if isinstance(before, float) and isinstance(after, float)
        else ""
    )
    items.append(
        (
            OK,
            f"the model holds the joshua sysid fit {fit.model} "
            f"({len(report.get('recordings', []))} recording(s)){tracked}",
        )
    )
    poor = report.get("fit", {})
    if poor.get("at_bounds") or poor.get("poorly_tracked"):
        items.append(
            (
                PROBLEM,
                f"the fit is poor: parameters at the edge of their range {poor.get('at_bounds') or 'none'}, joints "
                f"still missed {poor.get('poorly_tracked') or 'none'} (docs/sim-to-real.md#calibrate)",
            )
        )
    items.append(
        (
            YOU,
            f"record one more wave the fit has not seen and fit it on the calibrated model: joshua sysid NEW.csv "
            f"--model {fit.model}; factors near 1 and a tracking RMS near the report's say the model still is the arm",
        )
    )
    return fit


def _randomization(run: Run, fit: Any, items: list[tuple[str, str]]) -> None:
    events = [*run.task.reset_events, *run.task.interval_events]
    written = {event.key: event for event in run.task.spec.events}
    for event in events:
        spec = written.get(event.name)
        params = ", ".join(f"{key}={value}" for key, value in spec.params.items()) if spec else ""
        when = "at each episode's start" if event.mode == "reset" else f"every {event.interval} step(s)"
        term = spec.term if spec else event.function.__name__
        items.append((OK, f"trained with {event.name}: {term} ({params or 'its defaults'}), {when}"))
    if not events:
        items.append((TODO, "trained without randomization: the policy saw one exact model"))
    if run.task.curriculum is not None:
        strength = (run.record or {}).get(METRIC_PREFIX + CURRICULUM_METRIC)
        reached = f"{strength:.3g}" if isinstance(strength, int | float) else "not recorded"
        items.append(
            (
                OK,
                f"eased in by a curriculum on '{run.task.curriculum.metric}': strength at the last record {reached} "
                "(1: the full ranges above)",
            )
        )
    functions = {event.function for event in events}
    gaps = GAPS + (CAMERA_GAPS if run.task.cameras else ())
    missing = [name for name, terms in gaps if not functions.intersection(terms)]
    measured = [name for name in missing if fit is not None and name in SYSID_GAPS]
    if measured:
        items.append((OK, f"measured by the sysid fit rather than randomized: {', '.join(measured)}"))
    uncovered = [name for name in missing if name not in measured]
    if uncovered:
        items.append(
            (
                YOU,
                f"not randomized, so the arm must match the model there: {', '.join(uncovered)} "
                "(events: docs/tasks.md#domain-randomization)",
            )
        )
    items.append(
        (
            YOU,
            f"no event covers {UNCOVERED}: keep the arm's cables free, its supply at the rated voltage, and watch "
            "the first runs for them",
        )
    )


def _latency(run: Run, items: list[tuple[str, str]]) -> None:
    period_ms = run.period * 1000
    timestep, frame_skip = float(run.model.opt.timestep), run.task.frame_skip
    items.append(
        (
            OK,
            f"the policy runs every {period_ms:g} ms ({1 / run.period:g} Hz: timestep {timestep:g} s x frame_skip "
            f"{frame_skip}); joshua deploy runs it at this rate",
        )
    )
    delay = run.task.max_action_delay
    if delay:
        items.append(
            (
                OK,
                f"trained with up to {delay} step(s) of action delay: it tolerates about {delay * period_ms:g} ms from "
                "reading the joints to the servos taking the target",
            )
        )
        budget = f"{delay * period_ms:g} ms"
    else:
        items.append(
            (
                TODO,
                f"trained without action delay: the policy expects its target to act within its own step "
                f"({period_ms:g} ms); an action_delay event teaches it the arm's",
            )
        )
        budget = f"{period_ms:g} ms"
    items.append(
        (
            YOU,
            f"after command 2, deploy_report.json's latency_us.input_to_publish (a reading's arrival to its goal "
            f"sent, p50 and p99) plus the bus's read and write of the six servos must stay within {budget}; HOLDs "
            "in the report mean readings came later than --stale-after",
        )
    )


def _units(run: Run, robot_type: str | None, items: list[tuple[str, str]]) -> None:
    mode = run.task.spec.action.mode
    items.append(
        (
            OK,
            f"action mode '{mode}': targets in rad, scale and offset per actuator from the task "
            "(docs/sim-to-real.md#export); joshua deploy clips each to its joint's range",
        )
    )
    rows = [("joint", "range (rad)", "range (deg)", "LeRobot feature", "LeRobot at the ends")]
    features: list[str] = []
    if robot_type is not None:
        from joshua_lerobot import LeRobotUnits, feature_names

        features, _ = feature_names([joint for _, joint, _ in run.actuated()])
    for index, (actuator, joint, joint_range) in enumerate(run.actuated()):
        if joint_range is None:
            rows.append((joint or actuator, "unlimited", "", "", ""))
            continue
        low, high = joint_range
        lerobot = ""
        if features:
            ends = LeRobotUnits().from_model(features[index], np.array([low, high]), joint_range)
            lerobot = f"{ends[0]:.1f} .. {ends[1]:.1f} {'%' if features[index] == 'gripper.pos' else 'deg'}"
        rows.append(
            (
                joint,
                f"{low:.3f} .. {high:.3f}",
                f"{np.degrees(low):.1f} .. {np.degrees(high):.1f}",
                features[index] if features else "",
                lerobot,
            )
        )
    widths = [max(len(row[column]) for row in rows) for column in range(5)]
    items.extend(
        ("", "  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=True)).rstrip()) for row in rows
    )
    if robot_type is None:
        items.append(
            (
                YOU,
                "not an SO-10x arm: the robot's encoder and command topics carry radians, sim = robot + the "
                "mapping's offset",
            )
        )
        return
    items.append(
        (
            OK,
            f"the joints are the {robot_type}'s; joshua deploy --lerobot converts with lerobot's degrees "
            "(use_degrees=True): q = mid + radians(a) for the body, the gripper's 0..100 over its range "
            "(joshua_lerobot/joints.py)",
        )
    )
    items.append(
        (
            YOU,
            "with command 1 running, move each joint of the limp arm to its ends: lerobot reads about the last "
            "column there, and the twin reaches the same ends; a joint that moves the other way has its "
            "direction reversed",
        )
    )


def _calibration(run: Run, robot_type: str | None, args: argparse.Namespace, items: list[tuple[str, str]]) -> str:
    """The calibration file as the commands name it."""
    if robot_type is None:
        items.append(
            (
                YOU,
                "no LeRobot calibration: the MIRROR config's offsets are the calibration; set each with the arm at "
                "the model's zero pose",
            )
        )
        return "CALIBRATION.json"
    if args.calibration is None:
        items.append(
            (
                YOU,
                f"calibrate the arm once: lerobot-calibrate --robot.type={robot_type} --robot.port={args.port} "
                "--robot.id=my_arm, moving every joint through its whole range when asked; then check the file: "
                f"joshua checklist {args.run} --calibration FILE",
            )
        )
        items.append(
            (
                OK,
                "joshua deploy --lerobot refuses a missing or incomplete calibration file, and an arm whose servos "
                "hold another calibration than the file, before anything moves",
            )
        )
        return f"{CALIBRATION_DIR}/my_arm.json"
    from joshua_lerobot import feature_names, read_calibration

    motors = read_calibration(args.calibration)
    names, _ = feature_names([joint for _, joint, _ in run.actuated()])
    spans = []
    for name, (_, joint, joint_range) in zip(names, run.actuated(), strict=True):
        motor = motors[name.removesuffix(".pos")]
        if joint_range is not None:
            spans.append(
                f"{joint} {np.degrees(2 * motor.half_span):.0f} vs "
                f"{np.degrees(joint_range[1] - joint_range[0]):.0f} deg"
            )
    items.append(
        (OK, f"{args.calibration} has every motor with its range; calibrated vs model span: {', '.join(spans)}")
    )
    items.append(
        (
            YOU,
            "a span unlike the model's moves that joint's zero by up to half the difference: put the arm at the "
            "zero pose (upper arm up, forearm and gripper level and forward) with command 1 running and read the "
            "twin's angles; put what is left in the mirror config's offsets",
        )
    )
    return str(args.calibration)


def _deploy(run: Run, robot_type: str | None, port: str, calibration: str, items: list[tuple[str, str]]) -> None:
    if run.task.commands != {COMMAND: 3}:
        items.append(
            (
                PROBLEM,
                f"the task needs the commands {run.task.commands}; joshua deploy gives a policy only a '{COMMAND}' "
                "of 3 values",
            )
        )
    rate = 1 / run.period
    stop = f"kill -{ESTOP_SIGNAL.name.removeprefix('SIG')} PID" if robot_type else "true on the e-stop topic"
    items.append(
        (
            OK,
            f"joshua deploy's safety: targets within each joint's range, moving at most --max-speed (default "
            f"{DEFAULT_MAX_SPEED:g} rad/s, {DEFAULT_MAX_SPEED / rate:.3g} rad a step), HOLD when a reading is older "
            f"than --stale-after (default {DEFAULT_STALE_AFTER_S:g} s), e-stop latched ({stop}), stop in place on "
            "Ctrl-C, the arm left holding with its torque on",
        )
    )
    policy = run.policy_dir
    if robot_type is None:
        arm = "--config ARM.pbtxt"
        items.append((YOU, "1. read only, nothing sent: the twin follows the arm's encoder topics"))
        items.append(("", "joshua --config ARM.pbtxt"))
    else:
        arm = f"--lerobot {robot_type} --port {port} --calibration {calibration}"
        preset = LEROBOT_PRESETS[robot_type]
        items.append((YOU, "1. read only, nothing written to the arm: the twin follows the arm, moved by hand"))
        sets = (f"robot_type={robot_type}", f"port={port}", f"calibration={calibration}")
        items.append(
            ("", f"joshua --preset {preset} " + " ".join(f"--set simulation.mirror.lerobot.{value}" for value in sets))
        )
    target = "--target X,Y,Z"  # a point of the task's workspace, model frame (m)
    items.append(
        (
            YOU,
            "2. slow and short, ready to stop it (Ctrl-C): directions, units and latency (read deploy_report.json); "
            "a policy under a speed limit it never saw may circle its target",
        )
    )
    items.append(
        ("", f"joshua deploy {policy} {arm} {target} --max-speed {SLOW_SPEED:g} --duration {SLOW_DURATION_S:g}")
    )
    items.append((YOU, "3. at deploy's default speed limit, once 2 went as the twin did"))
    items.append(("", f"joshua deploy {policy} {arm} {target}"))
