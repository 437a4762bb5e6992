"""A serial-port fake of an SO-10x arm: six STS3215 servos behind a pty, answering Feetech protocol 0.

lerobot's own `FeetechMotorsBus` (with the scservo SDK and pyserial) opens the pty's other end as it opens
/dev/ttyACM0, so everything between a LeRobot robot and the wire runs for real. Each servo is its control table
(bytes, little-endian, as the STS3215 keeps it): PING, READ, WRITE, SYNC_READ and SYNC_WRITE work on it, the
position limits clamp the goal as the firmware does, and with torque on the present position moves towards the
goal at `SPEED_TICKS_PER_S`. With torque off it stays where `place` puts it (a leader arm moved by hand).
`mute` makes the arm stop answering (a cut cable, no power).
"""

from __future__ import annotations

import os
import select
import threading
import time
import tty

HEADER = b"\xff\xff"
BROADCAST = 0xFE
PING, READ, WRITE, SYNC_READ, SYNC_WRITE = 0x01, 0x02, 0x03, 0x82, 0x83
MODEL_NUMBER, STS3215 = 3, 777
FIRMWARE = (0, 1)  # major, minor version addresses
MIN_LIMIT, MAX_LIMIT = 9, 11
TORQUE_ENABLE, GOAL, PRESENT = 40, 42, 56
SPEED_TICKS_PER_S = 3000.0  # about 4.6 rad/s at 4096 ticks a turn: an STS3215 at full speed
MOTORS = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper")


class Servo:
    """One STS3215: its control table and where it is."""

    def __init__(self, servo_id: int, ticks: float) -> None:
        self.memory = bytearray(256)
        self.memory[FIRMWARE[0]], self.memory[FIRMWARE[1]] = 3, 10
        self.memory[MODEL_NUMBER : MODEL_NUMBER + 2] = STS3215.to_bytes(2, "little")
        self.memory[5] = servo_id
        self.ticks = ticks
        self.memory[GOAL : GOAL + 2] = int(ticks).to_bytes(2, "little")  # at power-on the goal is where it is
        self.moved_at = time.monotonic()

    def word(self, address: int) -> int:
        return int.from_bytes(self.memory[address : address + 2], "little")

    def update(self, now: float) -> None:
        """Move towards the goal for the time since the last update (torque on), and show where it is."""
        if self.memory[TORQUE_ENABLE]:
            goal = self.word(GOAL)
            low, high = self.word(MIN_LIMIT), self.word(MAX_LIMIT)
            if high > low:
                goal = min(max(goal, low), high)
            step = SPEED_TICKS_PER_S * (now - self.moved_at)
            self.ticks = min(max(goal, self.ticks - step), self.ticks + step)
        self.moved_at = now
        self.memory[PRESENT : PRESENT + 2] = round(self.ticks).to_bytes(2, "little")


class FeetechArm:
    """Six servos (ids 1..6) on a pty; `port` is the path a LeRobot robot opens. Use as a context manager."""

    def __init__(self, ticks: dict[int, float] | None = None) -> None:
        self.servos = {servo_id: Servo(servo_id, (ticks or {}).get(servo_id, 2048.0)) for servo_id in range(1, 7)}
        self.master, slave = os.openpty()
        tty.setraw(self.master)
        self.port = os.ttyname(slave)
        self._slave = slave
        self.lock = threading.Lock()
        self.muted = threading.Event()
        self.sync_reads = 0
        self.read_event = threading.Condition(self.lock)
        self.goals_written = 0  # goal positions written, one per servo
        self.goal_writes: list[dict[int, int]] = []  # each SYNC_WRITE of goal positions: servo id -> ticks
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="feetech-arm", daemon=True)

    def __enter__(self) -> FeetechArm:
        self._thread.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self._stop.set()
        self._thread.join()
        os.close(self.master)
        os.close(self._slave)

    def place(self, servo_id: int, ticks: float) -> None:
        """Put a servo at `ticks` (a hand moving a leader arm; with torque on, it then goes back to its goal)."""
        with self.lock:
            self.servos[servo_id].ticks = ticks

    def ticks(self) -> dict[int, int]:
        with self.lock:
            now = time.monotonic()
            for servo in self.servos.values():
                servo.update(now)
            return {servo_id: servo.word(PRESENT) for servo_id, servo in self.servos.items()}

    def torque(self) -> dict[int, int]:
        with self.lock:
            return {servo_id: servo.memory[TORQUE_ENABLE] for servo_id, servo in self.servos.items()}

    def goals(self) -> dict[int, int]:
        with self.lock:
            return {servo_id: servo.word(GOAL) for servo_id, servo in self.servos.items()}

    def wait_reads(self, count: int, timeout: float) -> bool:
        """Wait until `count` more SYNC_READs came (answered or not): what was written before them has arrived."""
        with self.read_event:
            wanted = self.sync_reads + count
            return self.read_event.wait_for(lambda: self.sync_reads >= wanted, timeout)

    def _serve(self) -> None:
        buffer = b""
        while not self._stop.is_set():
            ready, _, _ = select.select([self.master], [], [], 0.05)
            if not ready:
                continue
            packets, buffer = _split(buffer + os.read(self.master, 4096))
            for packet in packets:
                answer = self._answer(packet)
                if answer and not self.muted.is_set():
                    os.write(self.master, answer)

    def _answer(self, packet: bytes) -> bytes:
        servo_id, instruction, params = packet[2], packet[4], packet[5:-1]
        with self.lock:
            now = time.monotonic()
            for servo in self.servos.values():
                servo.update(now)
            if instruction == SYNC_READ:
                address, length, ids = params[0], params[1], params[2:]
                self.sync_reads += 1
                self.read_event.notify_all()
                return b"".join(
                    _status(i, self.servos[i].memory[address : address + length]) for i in ids if i in self.servos
                )
            if instruction == SYNC_WRITE:
                address, length, data = params[0], params[1], params[2:]
                written = {}
                for start in range(0, len(data), length + 1):
                    servo = self.servos.get(data[start])
                    if servo is not None:
                        servo.memory[address : address + length] = data[start + 1 : start + 1 + length]
                        written[data[start]] = servo.word(address)
                if address == GOAL:
                    self.goals_written += len(written)
                    self.goal_writes.append(written)
                return b""
            servo = self.servos.get(servo_id)
            if servo is None:
                return b""
            if instruction == PING:
                return _status(servo_id, b"")
            if instruction == READ:
                return _status(servo_id, servo.memory[params[0] : params[0] + params[1]])
            if instruction == WRITE:
                servo.memory[params[0] : params[0] + len(params) - 1] = params[1:]
                servo.update(now)
                return _status(servo_id, b"")
        return b""


def _split(buffer: bytes) -> tuple[list[bytes], bytes]:
    """The complete instruction packets at the start of `buffer` (a bad checksum skips a byte) and the rest."""
    packets = []
    while (start := buffer.find(HEADER)) >= 0:
        buffer = buffer[start:]
        if len(buffer) < 4 or len(buffer) < 4 + buffer[3]:
            return packets, buffer
        packet, end = buffer[: 4 + buffer[3]], 4 + buffer[3]
        if _checksum(packet[2:-1]) == packet[-1]:
            packets.append(packet)
            buffer = buffer[end:]
        else:
            buffer = buffer[1:]
    return packets, buffer[-1:] if buffer.endswith(HEADER[:1]) else b""


def _status(servo_id: int, data: bytes | bytearray) -> bytes:
    body = bytes([servo_id, len(data) + 2, 0, *data])
    return HEADER + body + bytes([_checksum(body)])


def _checksum(body: bytes) -> int:
    return ~sum(body) & 0xFF
