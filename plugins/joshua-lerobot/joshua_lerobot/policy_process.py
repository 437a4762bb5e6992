"""JOSHUA's side of a LeRobot policy served in a child process (`policy_server.py`, run by the Python that has
lerobot): start it, read what the policy is, and ask it for actions. JOSHUA's own environment never imports
lerobot or torch for this."""

from __future__ import annotations

import subprocess
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import numpy as np
from numpy.typing import NDArray

from joshua_core.errors import JoshuaError, UsageError
from joshua_lerobot import policy_server
from joshua_lerobot.policy_server import receive, send

SERVER = Path(policy_server.__file__)
CLOSE_SECONDS = 10.0  # a server whose requests ended exits at once; one that does not is killed after this
STDERR_TAIL = 400  # characters of the server's stderr quoted when it ends without a reply


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

    A Python that cannot run, has no lerobot, or cannot load the folder is a one-line UsageError (lerobot's own
    reason quoted); a policy that fails later is a JoshuaError."""

    def __init__(self, python: str, folder: Path, device: str) -> None:
        self.python = python
        self.stderr = tempfile.TemporaryFile()
        try:
            self.process = subprocess.Popen(
                [python, str(SERVER), str(folder), device],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=self.stderr,
            )
        except OSError as error:
            self.stderr.close()
            raise UsageError(f"--lerobot-python {python}: cannot run it: {error.strerror or error}") from None
        try:
            header, _ = self._reply(UsageError)
        except JoshuaError:
            self.close()
            raise
        described = header["policy"]

        def features(entries: Mapping[str, Any]) -> dict[str, PolicyFeature]:
            return {key: PolicyFeature(str(f["type"]), tuple(int(n) for n in f["shape"])) for key, f in entries.items()}

        self.description = PolicyDescription(
            str(described["type"]), features(described["input_features"]), features(described["output_features"])
        )

    def reset(self) -> None:
        """Clear the policy's queues (observation history, action chunks) before new episodes."""
        self._request({"op": "reset"})

    def select_action(
        self, state: NDArray[np.float32], images: Mapping[str, NDArray[np.uint8]], task: Sequence[str]
    ) -> NDArray[np.float32]:
        """The policy's actions (B, action) for a batch: `state` (B, state) and per image key (B, H, W, 3) RGB
        frames, `task` the text of each episode."""
        arrays = {"observation.state": state.astype(np.float32)} | dict(images)
        _, replied = self._request({"op": "select_action", "task": list(task)}, arrays)
        return replied["action"]

    def _request(
        self, header: dict[str, Any], arrays: dict[str, np.ndarray] | None = None
    ) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        assert self.process.stdin is not None
        try:
            send(self.process.stdin, header, arrays)
        except BrokenPipeError:
            pass  # the server ended: _reply says why
        return self._reply(JoshuaError)

    def _reply(self, error_type: type[JoshuaError]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        assert self.process.stdout is not None
        try:
            message = receive(self.process.stdout)
        except (EOFError, ValueError):
            message = None
        if message is None:
            code = self.process.wait()
            self.stderr.seek(0)
            tail = " ".join(self.stderr.read().decode(errors="replace").split())[-STDERR_TAIL:]
            raise error_type(
                f"--lerobot-python {self.python}: the policy process ended without a reply (exit {code}): "
                f"{tail or 'no output'}"
            )
        if "error" in message[0]:
            raise error_type(str(message[0]["error"]))
        return message

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
