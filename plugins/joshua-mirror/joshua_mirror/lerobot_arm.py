"""A real SO-10x arm through LeRobot's robot API: `LeRobotArm`, the `ArmTransport` of `joshua deploy --lerobot`
and of the MIRROR mode's `simulation.mirror.lerobot`.

lerobot's follower (`so100_follower`, `so101_follower`) or leader (`so100_leader`, `so101_leader`) is made from
its own config: the port, the calibration file (`calibration_dir`/`id`.json, as lerobot-calibrate wrote it) and
`use_degrees`. It is connected without lerobot's interactive calibration, and refused when the servos hold another
calibration than the file: the file's ranges are what the values are converted with. A `read_only` follower (the
mirror's) is connected at its bus only: the handshake and the reads, never lerobot's configure (which turns the
torque on) nor a goal, so the arm stays as it was; a leader is connected as lerobot-teleoperate connects it (its
torque off, so a hand moves it) and only read. A thread reads the arm
(`get_observation`, or a leader's `get_action`: one SYNC_READ of the six servos) every `period` and delivers the
values in radians through joshua-lerobot's joint table; `send` writes goal positions (`send_action`) under the
same lock, since the bus carries one packet at a time. A read the arm does not answer delivers nothing, so the
values go stale and the deploy holds; a port that fails (unplugged) stops the run.

Letting go never turns the torque off (`disable_torque_on_disconnect=False`): the servos keep holding their last
goal, where the stop in place put them, instead of letting the arm fall.
"""

from __future__ import annotations

import importlib
import importlib.util
import signal
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from joshua_core.errors import PluginNotFoundError, UsageError
from joshua_mirror.joints import MirroredJoint
from joshua_mirror.transport import ArmEvents, ArmTransport, RobotUnits

FOLLOWERS = ("so100_follower", "so101_follower")
LEADERS = ("so100_leader", "so101_leader")
ESTOP_SIGNAL = signal.SIGUSR1  # `kill -USR1 PID`: the e-stop of a deploy without ROS


class LeRobotArm(ArmTransport):
    """An SO-10x follower or leader connected through lerobot; `joints` in the order the values are delivered."""

    def __init__(
        self,
        robot_type: str,
        port: str,
        calibration: Path,
        units: RobotUnits,
        joints: list[MirroredJoint],
        *,
        period: float,
        estop_signal: bool = False,
        read_only: bool = False,
    ) -> None:
        self.robot_type, self.port, self.units, self.joints = robot_type, port, units, joints
        self.period = period
        self.estop_signal = estop_signal
        self.read_only = read_only or robot_type in LEADERS
        self.device = _connect(robot_type, port, calibration, units, bus_only=read_only and robot_type in FOLLOWERS)
        self.read = self.device.get_action if robot_type in LEADERS else self.device.get_observation
        self.lock = threading.Lock()  # one packet at a time on the bus: reads and writes
        self.stop = threading.Event()
        self.thread: threading.Thread | None = None
        self.reads = 0
        self.failed_reads = 0
        self.silence: str | None = None  # why the arm does not answer now
        self.said_silence: str | None = None
        self.lost: str | None = None  # the port failed: the run stops
        self.previous_handler: Any = None

    def start(self, events: ArmEvents) -> None:
        if self.estop_signal:
            self.previous_handler = signal.signal(ESTOP_SIGNAL, lambda *_: events.on_estop())
        self.thread = threading.Thread(target=self._read_until_stopped, args=(events,), name="joshua-lerobot-arm")
        self.thread.start()

    def _read_until_stopped(self, events: ArmEvents) -> None:
        features = [self.units.features[joint.joint] for joint in self.joints]
        next_read = time.monotonic()
        while not self.stop.wait(max(0.0, next_read - time.monotonic())) and self.lost is None:
            next_read = max(next_read + self.period, time.monotonic())
            try:
                with self.lock:
                    values = self.read()
            except ConnectionError as error:  # lerobot's "no status packet": the arm did not answer
                self.failed_reads += 1
                self.silence = _first_line(error)
                continue
            except OSError as error:  # the port itself failed (unplugged)
                self.lost = f"the arm's port {self.port} failed: {_first_line(error)}"
                return
            arrived = time.perf_counter_ns()
            self.reads += 1
            self.silence = None
            updates = [
                (index, self.units.to_radians(joint, float(values[feature])))
                for index, (joint, feature) in enumerate(zip(self.joints, features, strict=True))
            ]
            events.on_values(updates, arrived)

    def send(self, joints: Any, targets: NDArray[np.float64]) -> None:
        assert not self.read_only, "a read-only arm is never sent goals"
        action = {
            self.units.features[joint.joint]: self.units.from_radians(joint, float(target))
            for joint, target in zip(joints, targets, strict=True)
        }
        with self.lock:
            self.device.send_action(action)

    def poll(self) -> list[str]:
        silence = self.silence
        if silence == self.said_silence:
            return []
        self.said_silence = silence
        if silence is None:
            return [f"the arm on {self.port} answers again"]
        holding = "" if self.read_only else "; the servos hold their last goal"
        return [f"the arm on {self.port} does not answer ({silence}){holding}"]

    def broken(self) -> str | None:
        return "arm lost" if self.lost else None

    def error(self) -> str | None:
        return self.lost

    def status(self) -> str:
        return f" | arm reads {self.reads}" + (f", {self.failed_reads} unanswered" if self.failed_reads else "")

    def report(self) -> dict[str, Any]:
        return {"lerobot": self.robot_type, "port": self.port, "reads": self.reads, "unanswered": self.failed_reads}

    def close(self) -> None:
        self.stop.set()
        if self.thread is not None:
            self.thread.join()
        if self.previous_handler is not None:
            signal.signal(ESTOP_SIGNAL, self.previous_handler)
        if self.device.is_connected:
            try:
                self.device.disconnect()  # the port closes; the torque stays on (disable_torque_on_disconnect)
            except OSError:
                pass  # a port that failed is closed already

    def __enter__(self) -> LeRobotArm:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def follower_of(robot_type: str) -> str:
    """The follower whose arm (joints, units) `robot_type` has: a leader's follower, or the follower itself."""
    return robot_type.replace("_leader", "_follower")


def lerobot_units(body: str, calibration: Path | None, joints: list[MirroredJoint], *, option: str) -> RobotUnits:
    """LeRobot's units (`body`: degrees or range, with the arm's calibration file) for the mirrored `joints`, which
    must be the SO-ARM100's or the SO-101's six, each mapped to its SO-10x motor; `option` names where the units
    were asked for in the one-line errors. Converting needs joshua-lerobot."""
    if importlib.util.find_spec("joshua_lerobot") is None:
        raise PluginNotFoundError(f"{option} converts with joshua-lerobot: pip install joshua-lerobot")
    from joshua_lerobot import BodyUnits, LeRobotUnits, feature_names, read_calibration

    names, robot_type = feature_names([joint.joint for joint in joints])
    if robot_type is None:
        raise UsageError(f"{option} is for the SO-10x's six joints; the config mirrors {len(joints)} others")
    lerobot = LeRobotUnits(BodyUnits(body), None if calibration is None else read_calibration(calibration))
    features = {joint.joint: feature for joint, feature in zip(joints, names, strict=True)}
    return RobotUnits(lerobot, features, robot_type)


def _connect(robot_type: str, port: str, calibration: Path, units: RobotUnits, *, bus_only: bool) -> Any:
    """lerobot's robot (or leader) on `port` with the calibration file `calibration` (read by joshua-lerobot
    already), connected (`bus_only`: its motor bus only, nothing written); each problem one UsageError line, and the
    arm, if it was reached, left as it was."""
    try:
        if robot_type in LEADERS:
            importlib.import_module("lerobot.teleoperators.so_leader")  # registers the leaders' configs
            from lerobot.teleoperators import TeleoperatorConfig as Config
            from lerobot.teleoperators.utils import make_teleoperator_from_config as make
        else:
            importlib.import_module("lerobot.robots.so_follower")  # registers the followers' configs
            from lerobot.robots import RobotConfig as Config  # type: ignore[assignment, unused-ignore]
            from lerobot.robots.utils import make_robot_from_config as make  # type: ignore[assignment, unused-ignore]
        config_class = Config.get_choice_class(robot_type)
        extra = {} if robot_type in LEADERS else {"disable_torque_on_disconnect": False}
        config = config_class(
            port=port,
            id=calibration.stem,
            calibration_dir=calibration.parent,
            use_degrees=str(units.lerobot.body) == "degrees",
            **extra,
        )
        device = make(config)
    except ImportError as error:
        raise UsageError(
            f"a LeRobot arm needs lerobot with its Feetech servo SDK in this Python ({error}): "
            "pip install 'lerobot[feetech]'"
        ) from None
    try:
        if bus_only:
            device.bus.connect()
        else:
            device.connect(calibrate=False)
    except ConnectionError as error:
        cause = error.__cause__ or error
        raise UsageError(
            f"cannot open the arm's port {port}: {_first_line(cause)} (lerobot-find-port lists the ports)"
        ) from None
    except (RuntimeError, OSError) as error:  # the handshake: motors missing or silent
        _let_go(device)
        raise UsageError(
            f"the arm on {port} does not answer ({_first_line(error)}): is it powered, on this port, at 1 Mbaud?"
        ) from None
    if not device.is_calibrated:
        _let_go(device)
        raise UsageError(
            f"the arm on {port} holds another calibration than {calibration}: give the file lerobot-calibrate wrote "
            "for this arm, or calibrate it again"
        )
    return device


def _let_go(device: Any) -> None:
    """Close the port of a device that was refused (a follower's torque as it was)."""
    if device.is_connected:
        device.disconnect()


def _first_line(error: BaseException) -> str:
    lines = [line.strip() for line in str(error).splitlines() if line.strip()]
    return " ".join(lines[:2]) if lines else type(error).__name__
