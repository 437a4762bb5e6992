"""The MIRROR mode: a digital twin. The real arm's joint values move the simulated robot as they arrive.

The arm is read through an `ArmTransport`: ROS 2 topics (`MirrorTopics`: Float64 per joint or one JointState), or
an SO-10x arm through LeRobot (`LeRobotArm`, `simulation.mirror.lerobot`), a follower mirrored or a leader whose
values drive the simulated arm's actuators (teleoperation). Threads: the transport's thread applies every value the
moment it arrives (`Mirror.receive`; over ROS 2 it counts the messages lost before it, `TopicLoss`); the main
thread steps physics in real time when tracking through actuators, checks staleness, prints the status line and
the transport's warnings and feeds the display from a copy of the state, so rendering never delays a value.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from contextlib import ExitStack, nullcontext
from pathlib import Path
from typing import Any

import mujoco

from joshua_core.atomic import atomic_write_json, json_safe
from joshua_core.config_pb2 import SimulationConfig
from joshua_core.errors import ConfigError, JoshuaError, UsageError
from joshua_core.interfaces import Engine, Mode
from joshua_core.limits import MAX_CONTROL_HZ, MIN_CONTROL_HZ
from joshua_core.run_context import RunContext
from joshua_mirror.graph import TypeChecker
from joshua_mirror.joints import MirroredJoint, resolve_joints
from joshua_mirror.lerobot_arm import FOLLOWERS, LEADERS, LeRobotArm, follower_of, lerobot_units
from joshua_mirror.loss import TopicLoss
from joshua_mirror.mirror import Mirror
from joshua_mirror.options_pb2 import MirrorLeRobot, MirrorOptions
from joshua_mirror.recorder import Recorder
from joshua_mirror.ros import RosSession, message_types, sensor_qos
from joshua_mirror.transport import ArmEvents, ArmTransport, RobotUnits

REPORT_FILE = "mirror_report.json"
DEFAULT_JOINT_STATE_TOPIC = "/joint_states"
DEFAULT_NODE_NAME = "joshua_mirror"
DEFAULT_STALE_TIMEOUT_S = 0.5
DEFAULT_STATUS_PERIOD_S = 1.0
DEFAULT_DISPLAY_FPS = 30.0
STALE_CHECK_PERIOD_S = 0.05
WEB_FALLBACK = "mirroring without a display"  # what the mirror does when its web page cannot listen
QUEUE_DEPTH = 100  # messages kept per subscription if the callback thread falls behind
MAX_CATCH_UP_S = 0.25  # physics further behind the wall clock than this skips ahead instead of racing
GIL_SWITCH_INTERVAL_S = 2e-4  # the ROS thread gets the GIL within this while the main thread runs Python
FLOAT64_TYPE = "std_msgs/msg/Float64"
JOINT_STATE_TYPE = "sensor_msgs/msg/JointState"
DEFAULT_ARM_RATE_HZ = 60.0  # reads of a LeRobot arm per second: lerobot-teleoperate's default
LEROBOT_OPTION = "simulation.mirror.lerobot"


class MirrorMode(Mode):
    """Mirrors the real arm (its encoder topics, or a LeRobot arm) into the simulation until `duration` wall seconds
    pass, Ctrl-C, or the arm's port fails."""

    def run(self, config: SimulationConfig, context: RunContext) -> None:
        options: MirrorOptions = context.settings("mirror", config)
        _check_lerobot(options)
        with ExitStack() as stack:
            engine = stack.enter_context(context.create_engine(config))
            _check_mujoco(engine)
            mappings = context.settings("mirror_topic_mappings", config).mappings
            joints = resolve_joints(engine.model, mappings, options, by_topics=not options.lerobot.robot_type)
            units = _arm_units(options.lerobot, joints)
            arm = _open_arm(stack, options.lerobot, joints, units)  # before the twin's clock starts: lerobot loads
            mirror = Mirror(
                engine.model,
                engine.data,
                joints,
                options,
                stale_timeout=options.stale_timeout or DEFAULT_STALE_TIMEOUT_S,
            )
            recorder = None
            if options.record.csv or options.record.lerobot:
                teleop = options.lerobot.robot_type in LEADERS
                recorder = Recorder(joints, options.record, units=units, teleop=teleop)
            transport = arm or _open_topics(stack, options, mirror, recorder)
            transport.start(mirror)
            display = _open_display(stack, config, options, context, mirror)
            loop = _MainLoop(engine, mirror, transport, display, options)
            with recorder.sampling(mirror) if recorder else nullcontext():
                stopped_by = loop.run(config.duration)
            _warn(transport.poll())  # a last look: a problem that came during the final status period
            transport.close()  # nothing may change the state while it is reported
            report = {**_report(config, options, mirror, loop, stopped_by), **transport.report()}
            report["recording"] = recorder.write(config, context) if recorder else None
        path = context.output_dir / REPORT_FILE
        atomic_write_json(path, json_safe(report))  # NaN/inf are not JSON: null
        accepted = sum(joint["accepted"] for joint in report["joints"].values())
        lost = sum(report["lost_messages"].values())
        rejected = sum(
            joint["rejected_non_finite"] + joint["rejected_out_of_range"] for joint in report["joints"].values()
        )
        stale = [name for name, joint in report["joints"].items() if joint["stale"]]
        print(
            f"mirrored {len(joints)} joints for {report['wall_seconds']:.1f} s ({stopped_by}): {accepted} values "
            f"applied, {rejected} rejected, {lost} messages lost, stale at the end: {', '.join(stale) or 'none'}; "
            f"report: {path}"
        )
        problem = transport.error()
        if problem:
            raise ConfigError(problem)


def _check_lerobot(options: MirrorOptions) -> None:
    """`simulation.mirror.lerobot`, when set, names a LeRobot arm, its port and calibration, and nothing that only
    ROS 2 topics give; a leader drives the simulated arm's actuators."""
    arm = options.lerobot
    if not arm.robot_type:
        if arm.port or arm.calibration:
            raise ConfigError(f"{LEROBOT_OPTION} needs robot_type: one of {', '.join(FOLLOWERS + LEADERS)}")
        return
    if arm.robot_type not in FOLLOWERS + LEADERS:
        raise ConfigError(
            f"{LEROBOT_OPTION}.robot_type '{arm.robot_type}' is no LeRobot SO-10x arm: one of "
            f"{', '.join(FOLLOWERS + LEADERS)}"
        )
    if not arm.port:
        raise ConfigError(f"{LEROBOT_OPTION}.port is empty: the arm's serial port (lerobot-find-port lists them)")
    if not arm.calibration:
        raise ConfigError(f"{LEROBOT_OPTION}.calibration is empty: the arm's file, as lerobot-calibrate wrote it")
    if not MIN_CONTROL_HZ <= (arm.rate or DEFAULT_ARM_RATE_HZ) <= MAX_CONTROL_HZ:
        raise ConfigError(f"{LEROBOT_OPTION}.rate must be {MIN_CONTROL_HZ:g} to {MAX_CONTROL_HZ:g} reads per second")
    if options.command_topics:
        raise ConfigError(f"simulation.mirror.command_topics are ROS 2 topics; {LEROBOT_OPTION} reads no topic")
    if arm.robot_type in LEADERS and options.apply != MirrorOptions.ACTUATOR:
        raise ConfigError(
            f"a leader arm ({arm.robot_type}) teleoperates the simulated arm through its actuators: "
            "set simulation.mirror.apply=ACTUATOR"
        )


def _arm_units(arm: MirrorLeRobot, joints: list[MirroredJoint]) -> RobotUnits:
    """The units the arm's values are in: radians over ROS 2, LeRobot's (with the arm's calibration) through LeRobot,
    whose arm must be the model's (SO-100 or SO-101 joints)."""
    if not arm.robot_type:
        return RobotUnits()
    body = MirrorLeRobot.Units.Name(arm.units).lower()
    units = lerobot_units(body, Path(arm.calibration).expanduser(), joints, option=LEROBOT_OPTION)
    if units.robot_type != follower_of(arm.robot_type):
        raise ConfigError(
            f"{LEROBOT_OPTION}.robot_type {arm.robot_type} is another arm than the model's ({units.robot_type} joints)"
        )
    return units


def _open_arm(
    stack: ExitStack, arm: MirrorLeRobot, joints: list[MirroredJoint], units: RobotUnits
) -> LeRobotArm | None:
    """The LeRobot arm of `arm`, connected and only read, closed when `stack` closes; None over ROS 2."""
    if not arm.robot_type:
        return None
    period = 1.0 / (arm.rate or DEFAULT_ARM_RATE_HZ)
    calibration = Path(arm.calibration).expanduser()
    reader = LeRobotArm(arm.robot_type, arm.port, calibration, units, joints, period=period, read_only=True)
    return stack.enter_context(reader)


def _open_topics(stack: ExitStack, options: MirrorOptions, mirror: Mirror, recorder: Recorder | None) -> MirrorTopics:
    """The ROS 2 topics of the mirror's mappings, read by a node that `stack` closes."""
    ros = stack.enter_context(RosSession(options.node_name or DEFAULT_NODE_NAME))
    return MirrorTopics(ros, mirror, options, recorder)


def _check_mujoco(engine: Engine) -> None:
    if not isinstance(engine.model, mujoco.MjModel) or not isinstance(engine.data, mujoco.MjData):
        raise UsageError("the MIRROR mode needs a MuJoCo-based backend (its engine's model must be a mujoco.MjModel)")


class _UnknownTopicWatcher:
    """Counts messages on Float64 topics next to the mapped ones (same namespace) that no mapping names."""

    def __init__(self, ros: RosSession, mirror: Mirror, mapped: set[str], float64: Any) -> None:
        self.ros = ros
        self.mirror = mirror
        self.mapped = mapped
        self.namespaces = {topic.rsplit("/", 1)[0] for topic in mapped}
        self.float64 = float64
        self.watched: set[str] = set()

    def poll(self) -> None:
        """Subscribe to new unmapped Float64 topics in the graph; their messages are only counted."""
        for topic, types in self.ros.node.get_topic_names_and_types():
            if (
                FLOAT64_TYPE in types
                and topic not in self.mapped
                and topic not in self.watched
                and topic.rsplit("/", 1)[0] in self.namespaces
            ):
                self.watched.add(topic)
                self.ros.subscribe(self.float64, topic, self._counter(topic), sensor_qos(1))

    def _counter(self, topic: str) -> Callable[[Any], None]:
        def count(_message: Any) -> None:
            self.mirror.count_unknown(topic)

        return count


class MirrorTopics(ArmTransport):
    """The arm behind ROS 2 topics, as the mirror reads them: the encoder subscriptions (counting the messages lost
    on each, unknown JointState names and malformed messages into `mirror`), unmapped Float64 topics beside the
    mapped ones (counted), the recorder's command topics, and publishers of another type in the graph."""

    def __init__(self, ros: RosSession, mirror: Mirror, options: MirrorOptions, recorder: Recorder | None) -> None:
        self.ros = ros
        self.mirror = mirror
        self.options = options
        self.recorder = recorder
        self.joints = mirror.joints
        self.units = RobotUnits()
        self.watcher: _UnknownTopicWatcher | None = None
        self.types = TypeChecker(ros.node, _expected_types(ros, mirror, options))

    def start(self, events: ArmEvents) -> None:
        self.watcher = _subscribe(self.ros, self.mirror, events, self.options)
        _subscribe_commands(self.ros, self.recorder)

    def poll(self) -> list[str]:
        if self.watcher is not None:
            self.watcher.poll()
        return [f"wrong message type: {line}" for line in self.types.poll()]

    def error(self) -> str | None:
        return self.types.error()

    def status(self) -> str:
        return self.types.status()

    def page(self) -> list[str]:
        wrong = sorted(self.types.current.items())
        return [f"- **WRONG TYPE** {topic}: published as {kinds}" for topic, kinds in wrong]

    def report(self) -> dict[str, Any]:
        return {"type_mismatches": self.types.seen}

    def close(self) -> None:
        self.ros.close()


def _subscribe(
    ros: RosSession, mirror: Mirror, events: ArmEvents, options: MirrorOptions
) -> _UnknownTopicWatcher | None:
    """Create the subscriptions whose callbacks feed `events` (their topic names checked by `resolve_joints`) and
    count the messages lost on each into `mirror`."""
    float64, joint_state = message_types()
    qos = sensor_qos(QUEUE_DEPTH)
    node = ros.node
    if options.message_type == MirrorOptions.JOINT_STATE:
        topic = node.resolve_topic_name(options.joint_state_topic or DEFAULT_JOINT_STATE_TOPIC)
        by_name = {joint.source: index for index, joint in enumerate(mirror.joints)}
        loss = mirror.track_loss(topic, lambda: node.count_publishers(topic))

        def on_joint_state(message: Any, info: dict[str, Any]) -> None:
            entered = time.perf_counter_ns()
            names, positions = message.name, message.position
            if len(positions) < len(names):
                mirror.malformed += 1
            else:
                updates = []
                for name, position in zip(names, positions, strict=False):
                    index = by_name.get(name)
                    if index is None:
                        mirror.count_unknown(name)
                    else:
                        updates.append((index, position))
                events.on_values(updates, entered)
            loss.see(info["publication_sequence_number"])  # after the update: it adds no latency

        ros.subscribe(joint_state, topic, on_joint_state, qos)
        return None

    mapped = set()
    for index, joint in enumerate(mirror.joints):
        topic = node.resolve_topic_name(joint.source)
        loss = mirror.track_loss(topic, lambda topic=topic: node.count_publishers(topic))
        ros.subscribe(float64, topic, _float64_callback(events, index, loss), qos)
        mapped.add(topic)
    return _UnknownTopicWatcher(ros, mirror, mapped, float64)


def _subscribe_commands(ros: RosSession, recorder: Recorder | None) -> None:
    """Subscribe to the command topics whose values the recorder keeps (only when recording)."""
    if recorder is None:
        return
    float64, _ = message_types()
    for index, joint in enumerate(recorder.joints):
        if joint.command_topic:
            ros.subscribe(float64, joint.command_topic, recorder.command_callback(index), sensor_qos(QUEUE_DEPTH))


def _expected_types(ros: RosSession, mirror: Mirror, options: MirrorOptions) -> dict[str, str]:
    """Each subscribed topic (resolved name) -> the message type the mirror reads from it."""
    node = ros.node
    if options.message_type == MirrorOptions.JOINT_STATE:
        expected = {node.resolve_topic_name(options.joint_state_topic or DEFAULT_JOINT_STATE_TOPIC): JOINT_STATE_TYPE}
    else:
        expected = {node.resolve_topic_name(joint.source): FLOAT64_TYPE for joint in mirror.joints}
    if options.record.csv or options.record.lerobot:
        commands = [joint.command_topic for joint in mirror.joints if joint.command_topic]
        expected |= {node.resolve_topic_name(topic): FLOAT64_TYPE for topic in commands}
    return expected


def _warn(lines: list[str]) -> None:
    """The transport's problems, one line each (e.g. a wrong message type, an arm that does not answer)."""
    for line in lines:
        print(f"joshua: mirror: {line}", file=sys.stderr, flush=True)


def _float64_callback(events: ArmEvents, index: int, loss: TopicLoss) -> Any:
    def on_float64(message: Any, info: dict[str, Any]) -> None:
        events.on_values([(index, message.data)], time.perf_counter_ns())
        loss.see(info["publication_sequence_number"])  # after the update: it adds no latency

    return on_float64


def _open_display(
    stack: ExitStack, config: SimulationConfig, options: MirrorOptions, context: RunContext, mirror: Mirror
) -> _DisplayFeed | None:
    """The display the mirror options ask for (None for NONE), on an engine of its own from the config's backend; a
    set `simulation.web` (`--web`) means WEB, a web page that also shows the topics' status.

    It shows its first frame (the start pose) before it is announced, so "display: ..." means it is up.
    """
    choice = MirrorOptions.WEB if config.web else options.display
    if choice == MirrorOptions.NONE:
        return None
    # here: mujoco's viewer, OpenCV and viser load only when a display is asked for
    from joshua_render import open_display, open_web_display

    shadow = stack.enter_context(context.create_engine(config))
    fps = options.display_fps or DEFAULT_DISPLAY_FPS
    if choice == MirrorOptions.WEB:
        page = open_web_display(
            shadow.model, shadow.data, config.web, title="JOSHUA mirror", instead=WEB_FALLBACK, controls=False
        )
        if page is None:
            return None
        display = stack.enter_context(page)
    else:
        viewer = {MirrorOptions.AUTO: None, MirrorOptions.VIEWER: True, MirrorOptions.RECORD: False}[choice]
        display = stack.enter_context(
            open_display(
                shadow,
                output_dir=context.output_dir,
                name="mirror",
                fps=fps,
                camera=options.camera or None,
                viewer=viewer,
            )
        )
    feed = _DisplayFeed(shadow, display, fps, shows_status=choice == MirrorOptions.WEB)
    feed.show(mirror, 0.0)
    print(f"joshua: mirror: display: {display.description}", file=sys.stderr)
    return feed


class _DisplayFeed:
    """Copies the mirrored state into the display's own engine (under the lock, microseconds) and renders it there;
    a web page also gets the topics' status (`shows_status`)."""

    def __init__(self, shadow: Any, display: Any, fps: float, *, shows_status: bool = False) -> None:
        self.shadow = shadow
        self.display = display
        self.period = 1.0 / fps
        self.shows_status = shows_status
        self.shown = 0  # frames shown so far (the status line says it: one can tell a frame came after an event)

    def show(self, mirror: Mirror, elapsed: float) -> bool:
        """Render the current state; False once the user closed the viewer."""
        source, target = mirror.data, self.shadow.data
        with mirror.lock:
            target.qpos[:] = source.qpos
            target.qvel[:] = source.qvel
            target.ctrl[:] = source.ctrl
            target.act[:] = source.act
            target.time = source.time
        mujoco.mj_forward(self.shadow.model, target)
        still_open = bool(self.display.update(elapsed))
        self.shown += 1
        return still_open

    def show_status(self, mirror: Mirror, transport: ArmTransport) -> None:
        """The arm's status on a web page (each status period); nothing for the viewer or a recording."""
        if self.shows_status:
            self.display.set_report(status_page(mirror, transport))


def status_page(mirror: Mirror, transport: ArmTransport) -> str:
    """The mirror's status as Markdown: per joint its last value, age, STALE and rejections, and the tracking error
    when physics follows the values; then lost messages, the transport's lines (wrong message types) and unknown
    names."""
    now = mirror.clock()
    lines = ["**mirror status**", ""]
    for joint, stats in zip(mirror.joints, mirror.stats, strict=True):
        value = "no value yet" if stats.last_value is None else f"{stats.last_value:+.3f}"
        age = "" if stats.last_accepted_at is None else f", {(now - stats.last_accepted_at) * 1e3:.0f} ms ago"
        flags = " **STALE**" if stats.stale else ""
        flags += f", rejected {stats.rejected}" if stats.rejected else ""
        line = f"- {joint.joint} ({joint.source}): {value}{age}{flags}"
        if mirror.actuated:
            error = stats.error_summary()
            line += (
                ", tracking error: no sample yet"
                if error["rms"] is None
                else f", tracking error RMS {error['rms']:.4f} max {error['max_abs']:.4f}"
            )
        lines.append(line)
    lost = {topic: loss.lost for topic, loss in sorted(mirror.loss.items()) if loss.lost}
    lines.append("")
    lines.append("lost messages: " + (", ".join(f"{topic} {n}" for topic, n in lost.items()) or "none"))
    lines.extend(transport.page())
    unknown = sum(mirror.unknown_names.values())
    if unknown:
        lines.append(f"unknown names or topics: {unknown} messages")
    return "\n".join(lines)


class _MainLoop:
    """Real-time physics (when tracking through actuators), staleness, status lines and display, until done."""

    def __init__(
        self,
        engine: Engine,
        mirror: Mirror,
        transport: ArmTransport,
        display: _DisplayFeed | None,
        options: MirrorOptions,
    ) -> None:
        self.engine = engine
        self.mirror = mirror
        self.transport = transport
        self.display = display
        period = options.status_period or DEFAULT_STATUS_PERIOD_S
        self.print_status = period > 0  # a negative period turns the lines off; the watcher still polls
        self.status_period = period if period > 0 else DEFAULT_STATUS_PERIOD_S
        self.steps = 0
        self.skipped_steps = 0
        self.wall_seconds = 0.0

    def run(self, duration: float) -> str:
        """Loop until `duration` wall seconds (0: until Ctrl-C) or the transport breaks; return what stopped it."""
        switch_interval = sys.getswitchinterval()
        sys.setswitchinterval(GIL_SWITCH_INTERVAL_S)
        start = time.monotonic()
        try:
            return self._loop(start, start + duration if duration > 0 else float("inf"))
        except KeyboardInterrupt:
            return "Ctrl-C"
        finally:
            sys.setswitchinterval(switch_interval)
            self.wall_seconds = time.monotonic() - start

    def _loop(self, start: float, deadline: float) -> str:
        timestep = self.engine.timestep
        next_stale_check = start + STALE_CHECK_PERIOD_S
        next_status = start + self.status_period
        _warn(self.transport.poll())
        next_frame = start
        while True:
            now = time.monotonic()
            if now >= deadline:
                return "duration"
            if self.mirror.actuated:
                self._step_physics(now - start, timestep)
            if now >= next_stale_check:
                next_stale_check = now + STALE_CHECK_PERIOD_S
                _warn_stale(self.mirror.update_staleness(), self.mirror.stale_timeout)
            if now >= next_status:
                next_status = now + self.status_period
                _warn(self.transport.poll())
                broken = self.transport.broken()
                if broken:
                    return broken
                _warn_loss(self.mirror.loss_warning())
                if self.display is not None:
                    self.display.show_status(self.mirror, self.transport)
                if self.print_status:
                    print(self._status_line(), file=sys.stderr, flush=True)
            if self.display is not None and now >= next_frame:
                next_frame = now + self.display.period
                if not self.display.show(self.mirror, now - start):
                    return "viewer closed"
            wake = min(deadline, next_stale_check, next_status, next_frame if self.display else deadline)
            if self.mirror.actuated:
                wake = min(wake, start + (self.steps + self.skipped_steps + 1) * timestep)
            time.sleep(max(0.0, wake - time.monotonic()))

    def _status_line(self) -> str:
        line = self.mirror.status_line(self.status_period) + self.transport.status()
        return line if self.display is None else f"{line} | display {self.display.shown} frames"

    def _step_physics(self, elapsed: float, timestep: float) -> None:
        """Step until simulated time catches up with wall time, one step per lock so messages wait at most one."""
        due = int(elapsed / timestep) - self.steps - self.skipped_steps
        if due * timestep > MAX_CATCH_UP_S:
            skip = due - int(MAX_CATCH_UP_S / timestep)
            self.skipped_steps += skip
            due -= skip
        for _ in range(due):
            with self.mirror.lock:
                self.engine.step()
            self.steps += 1
        problem = self.engine.instability()
        if problem:
            raise JoshuaError(f"simulation diverged at t = {self.engine.time:.3f} s: {problem}")


def _warn_stale(joints: list[MirroredJoint], timeout: float) -> None:
    """One line for the joints that just went stale (e.g. all of them when the publisher is lost)."""
    if joints:
        names = ", ".join(f"{joint.joint} ({joint.source})" for joint in joints)
        print(f"joshua: mirror: stale, no valid value for {timeout:g} s: {names}", file=sys.stderr)


def _warn_loss(line: str | None) -> None:
    if line:
        _warn([line])


def _report(
    config: SimulationConfig, options: MirrorOptions, mirror: Mirror, loop: _MainLoop, stopped_by: str
) -> dict[str, Any]:
    return {
        "model_path": config.model_path,
        "apply": MirrorOptions.Apply.Name(options.apply),
        "message_type": MirrorOptions.MessageType.Name(options.message_type),
        "stopped_by": stopped_by,
        "wall_seconds": loop.wall_seconds,
        "physics_steps": loop.steps,
        "physics_steps_skipped": loop.skipped_steps,
        "stale_timeout_s": mirror.stale_timeout,
        **mirror.report(),
    }
