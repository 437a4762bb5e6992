"""JOSHUA's side of a LeRobot policy served in a child process (`policy_server.py`, run by the Python that has
lerobot): start it, read what the policy is, and ask it for actions. JOSHUA's own environment never imports
lerobot or torch for this."""

from __future__ import annotations

import os
import select
import subprocess
import tempfile
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, NoReturn, Self

import numpy as np
from numpy.typing import NDArray

from joshua_core.errors import UsageError
from joshua_lerobot import policy_server
from joshua_lerobot.policy_server import receive, send
from joshua_lerobot.writer import ACTION

SERVER = Path(policy_server.__file__)
CLOSE_SECONDS = 10.0  # a server whose requests ended exits at once; one that does not is killed after this
STDERR_TAIL = 400  # characters of the server's stderr quoted when it ends without a reply
MAX_REPLY_BYTES = 1 << 26  # a reply holds one batch of actions


@dataclass(frozen=True)
class PolicyFeature:
    """One input or output of a LeRobot policy, as its config.json declares it: type (STATE, VISUAL, ACTION ...)
    and shape (images channels first)."""

    type: str
    shape: tuple[int, ...]


@dataclass(frozen=True)
class PolicyDescription:
    """What a loaded LeRobot policy is: its type (e.g. "act") and its input and output features by key."""

    type: str
    inputs: Mapping[str, PolicyFeature]
    outputs: Mapping[str, PolicyFeature]


class PolicyProcess:
    """A LeRobot pretrained policy (`folder`) loaded on `device` by `python` in a child process; a context manager.

    The policy is the user's input: a Python that cannot run, has no lerobot or cannot load the folder, and a
    policy that fails, answers what is not a message, answers with actions that are not one finite row per
    observation, ends, or takes longer than `reply_seconds` for a reply (loading included) is a one-line
    UsageError (lerobot's own reason quoted where it gave one), and the child process is stopped."""

    def __init__(self, python: str, folder: Path, device: str, reply_seconds: float) -> None:
        self.python, self.reply_seconds = python, reply_seconds
        self.stderr = tempfile.TemporaryFile()
        try:
            self.process = subprocess.Popen(
                [python, str(SERVER), str(folder), device],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=self.stderr,
                bufsize=0,  # replies are read from the pipe itself, with a deadline (_DeadlineReader)
            )
        except OSError as error:
            self.stderr.close()
            raise UsageError(f"--lerobot-python {python}: cannot run it: {error.strerror or error}") from None
        try:
            header, _ = self._reply()
            self.description = _description(header)
        except UsageError:
            self.close()
            raise

    def reset(self) -> None:
        """Clear the policy's queues (observation history, action chunks) before new episodes."""
        self._request({"op": "reset"})

    def select_action(
        self, state: NDArray[np.float32], images: Mapping[str, NDArray[np.uint8]], task: Sequence[str]
    ) -> NDArray[np.float32]:
        """The policy's actions (B, action) for a batch: `state` (B, state) and per image key (B, H, W, 3) RGB
        frames, `task` the text of each episode. Anything but one finite row per observation, as wide as the
        policy's `action` feature, is refused: a row is never spread over several environments."""
        arrays = {"observation.state": state.astype(np.float32)} | dict(images)
        _, replied = self._request({"op": "select_action", "task": list(task)}, arrays)
        action = replied.get("action")
        feature = self.description.outputs.get(ACTION)
        expected = (len(state), *(feature.shape if feature is not None else ()))
        if action is None or action.shape != expected:
            shape = "no action" if action is None else f"actions of shape {list(action.shape)}"
            self._fail(f"answered a batch of {len(state)} observations with {shape}, not {list(expected)}")
        if not np.isfinite(action).all():
            rows = int((~np.isfinite(action).all(axis=1)).sum())
            self._fail(f"answered with non-finite actions (NaN or infinity) in {rows} of {len(state)} rows")
        return action.astype(np.float32)

    def _request(
        self, header: dict[str, Any], arrays: dict[str, np.ndarray] | None = None
    ) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        assert self.process.stdin is not None
        try:
            send(self.process.stdin, header, arrays)
        except BrokenPipeError:
            pass  # the server ended: _reply says why
        return self._reply()

    def _reply(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        assert self.process.stdout is not None
        try:
            message = receive(_DeadlineReader(self.process.stdout.fileno(), self.reply_seconds), MAX_REPLY_BYTES)
        except TimeoutError:
            self._fail(f"did not answer within {self.reply_seconds:g} s (--lerobot-timeout)")
        except (EOFError, ValueError) as error:  # json's and the layout's errors are ValueErrors
            self._fail(f"sent what is not a reply ({' '.join(str(error).split())[:200]})")
        if message is None:
            code = self.process.wait()
            self.stderr.seek(0)
            tail = " ".join(self.stderr.read().decode(errors="replace").split())[-STDERR_TAIL:]
            raise UsageError(
                f"--lerobot-python {self.python}: the policy process ended without a reply (exit {code}): "
                f"{tail or 'no output'}"
            )
        if "error" in message[0]:
            raise UsageError(str(message[0]["error"]))
        return message

    def _fail(self, what: str) -> NoReturn:
        """Stop the child process and say what it did."""
        self.process.kill()
        raise UsageError(f"--lerobot-python {self.python}: the policy process {what}; stopped it")

    def close(self) -> None:
        """End the child process (its requests end, so it exits) and release its pipes."""
        for stream in (self.process.stdin, self.process.stdout):
            if stream is not None:
                try:
                    stream.close()
                except BrokenPipeError:
                    pass
        try:
            self.process.wait(CLOSE_SECONDS)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.stderr.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, error: BaseException | None, traceback: TracebackType | None
    ) -> None:
        self.close()


def _description(header: Mapping[str, Any]) -> PolicyDescription:
    """The policy its first reply describes; a reply that does not is a ValueError's one line as a UsageError."""
    try:
        described = header["policy"]

        def features(entries: Mapping[str, Any]) -> dict[str, PolicyFeature]:
            return {key: PolicyFeature(str(f["type"]), tuple(int(n) for n in f["shape"])) for key, f in entries.items()}

        return PolicyDescription(
            str(described["type"]), features(described["input_features"]), features(described["output_features"])
        )
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise UsageError(f"the policy process described its policy wrongly ({type(error).__name__}: {error})") from None


class _DeadlineReader:
    """`read(size)` on a pipe's descriptor that raises TimeoutError once `seconds` from its making have passed,
    so that one reply, however a peer dribbles it out, takes at most that long."""

    def __init__(self, fd: int, seconds: float) -> None:
        self.fd, self.end = fd, time.monotonic() + seconds

    def read(self, size: int) -> bytes:
        chunks: list[bytes] = []
        got = 0
        while got < size:
            left = self.end - time.monotonic()
            if left <= 0 or not select.select([self.fd], [], [], left)[0]:
                raise TimeoutError
            chunk = os.read(self.fd, min(size - got, 1 << 20))
            if not chunk:
                break  # the stream ended: the caller sees a short read
            chunks.append(chunk)
            got += len(chunk)
        return b"".join(chunks)
