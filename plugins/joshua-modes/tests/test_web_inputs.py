"""What a browser sends to the web page is checked against its control before the run sees it.

A raw WebSocket client (a broken or hostile page speaks the same protocol) sends a real `joshua --web` run
values its controls do not take: NaN, huge, negative and out-of-range numbers, strings for numbers, other
properties than the value, bad body-dragging poses, a value for a control the page alone sets. Each is ignored:
the control is set back to the value in force, the terminal gets one warning line per control and no traceback,
and the run goes on to its end (before the check, a NaN speed crashed INTERACTIVE and a NaN scrub made a
PASSIVE replay never end).
"""

from __future__ import annotations

import contextlib
import math
import re
import subprocess
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from modes_testing import JOSHUA_SCRIPT, headless_env

pytest.importorskip("viser", reason="the web display needs viser (pip install 'joshua-render[web]')")

import msgspec  # noqa: E402
import viser  # noqa: E402
import zstandard  # noqa: E402
from websockets.sync.client import ClientConnection, connect  # noqa: E402

WAIT_S = 60.0  # the longest any one thing is waited for (2 busy cores)
NAN = math.nan
CAMERA_MESSAGE = {  # viser's ViewerCameraMessage, which a browser sends once the page has loaded: from then on
    "type": "ViewerCameraMessage",  # viser counts the client and runs the callbacks of what it sets
    "wxyz": (1.0, 0.0, 0.0, 0.0),
    "position": (0.0, -2.0, 1.0),
    "fov": 1.0,
    "near": 0.01,
    "far": 100.0,
    "image_height": 600,
    "image_width": 800,
    "look_at": (0.0, 0.0, 0.0),
    "up_direction": (0.0, 0.0, 1.0),
}


class JoshuaRun:
    """`joshua ARGS --web 127.0.0.1:0` in `folder`: its port once it listens, its stderr lines as they come."""

    def __init__(self, args: list[str], folder: Path) -> None:
        self.process = subprocess.Popen(
            [str(JOSHUA_SCRIPT), *args, "--web", "127.0.0.1:0"],
            cwd=folder,
            env=headless_env(),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.stderr: list[str] = []
        self._port: list[int] = []
        self._listening = threading.Event()
        threading.Thread(target=self._read_stdout, daemon=True).start()
        self._stderr_thread = threading.Thread(target=self._read_stderr, daemon=True)
        self._stderr_thread.start()

    def _read_stdout(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            if match := re.match(r"web display: http://127\.0\.0\.1:(\d+)/", line):
                self._port.append(int(match[1]))
                self._listening.set()
        self._listening.set()  # it ended without listening: `port` says so

    def _read_stderr(self) -> None:
        assert self.process.stderr is not None
        self.stderr.extend(self.process.stderr)

    @property
    def port(self) -> int:
        assert self._listening.wait(WAIT_S) and self._port, f"no web display: {''.join(self.stderr)}"
        return self._port[0]

    def finish(self) -> str:
        """Its exit status (0 or the test fails) once it ends on its own; its whole stderr."""
        status = self.process.wait(WAIT_S)
        self._stderr_thread.join(WAIT_S)
        err = "".join(self.stderr)
        assert status == 0, err
        return err


@contextlib.contextmanager
def joshua_web(args: list[str], folder: Path) -> Iterator[JoshuaRun]:
    run = JoshuaRun(args, folder)
    try:
        yield run
    finally:
        if run.process.poll() is None:
            run.process.kill()
        run.process.wait(WAIT_S)


class PageClient:
    """A WebSocket client of the page, as viser's browser client speaks: it learns the controls (label -> uuid)
    from the messages the server sends, records their values as the server sends them, and sends values."""

    def __init__(self, port: int) -> None:
        self._socket: ClientConnection = connect(
            f"ws://127.0.0.1:{port}", subprotocols=[f"viser-v{viser.__version__}"], open_timeout=WAIT_S
        )
        self._changed = threading.Condition()
        self.uuids: dict[str, str] = {}
        self.props: dict[str, dict[str, Any]] = {}  # label -> the control's properties when created
        self.values: dict[str, list[Any]] = {}  # uuid -> every value the server sent for it, in order
        self.poses: dict[str, list[tuple[str, Any]]] = {}  # scene node -> ("wxyz" | "position", value) sent
        threading.Thread(target=self._receive, daemon=True).start()
        self._send(CAMERA_MESSAGE)

    def close(self) -> None:
        self._socket.close()

    def _receive(self) -> None:
        decompressor = zstandard.ZstdDecompressor()
        with contextlib.suppress(Exception):  # the server stops at the end of the run
            for raw in self._socket:
                assert isinstance(raw, bytes)
                size, compressed = int.from_bytes(raw[:8], "little"), int.from_bytes(raw[8:16], "little")
                inner = decompressor.decompress(raw[16 : 16 + compressed], max_output_size=size)
                with self._changed:
                    for message in msgspec.msgpack.decode(inner)["messages"]:
                        self._record(message)
                    self._changed.notify_all()

    def _record(self, message: dict[str, Any]) -> None:
        kind = message["type"]
        if kind.startswith("Gui") and "label" in message.get("props", {}):
            self.uuids.setdefault(message["props"]["label"], message["uuid"])
            self.props.setdefault(message["props"]["label"], message["props"])
            self.values.setdefault(message["uuid"], []).append(message.get("value"))
        elif kind == "GuiUpdateMessage" and "value" in message["updates"]:
            self.values.setdefault(message["uuid"], []).append(message["updates"]["value"])
        elif kind in ("SetPositionMessage", "SetOrientationMessage"):
            field = "position" if kind == "SetPositionMessage" else "wxyz"
            self.poses.setdefault(message["name"], []).append((field, message[field]))

    def wait_for(self, condition: Callable[[], object]) -> None:
        with self._changed:
            assert self._changed.wait_for(condition, timeout=WAIT_S)

    def wait_paused(self) -> None:
        self.wait_for(lambda: any(str(value).lower().startswith("paused") for value in self.sent("status")))

    def sent(self, label: str) -> list[Any]:
        """The values the server sent for the control `label` so far (none before the page has it)."""
        return list(self.values.get(self.uuids.get(label, ""), []))

    def send(self, label: str, value: object, *, other: dict[str, object] | None = None) -> None:
        """Set control `label` to `value` as a browser does (or send the `other` properties instead)."""
        self.wait_for(lambda: label in self.uuids)
        updates = {"value": value} if other is None else other
        self._send({"type": "GuiUpdateMessage", "uuid": self.uuids[label], "updates": updates})

    def send_pose(self, name: str, wxyz: object, position: object) -> None:
        """Drag the gizmo `name` to a pose, as a browser does."""
        self._send({"type": "TransformControlsUpdateMessage", "name": name, "wxyz": wxyz, "position": position})

    def _send(self, message: dict[str, object]) -> None:
        self._socket.send(msgspec.msgpack.encode(message))

    def set_back(self, label: str, since: int, value: object) -> None:
        """Wait until the server sent control `label` `value` after its first `since` values (the value in force,
        sent back to the browsers after what it ignored)."""
        self.wait_for(lambda: value in self.values[self.uuids[label]][since:])


def warnings_for(err: str, label: str) -> list[str]:
    return [
        line for line in err.splitlines() if line.startswith("joshua: warning: web display: ignored") and label in line
    ]


def test_interactive_page_ignores_what_its_controls_do_not_take(tmp_path: Path) -> None:
    bad = {  # label: values its control does not take (sent while paused, so that the run waits for them)
        "speed (x real time)": [NAN, 1e300, -5.0, 100.0, 0.0, "0.5", True, [1.0], None],
        "Reset": ["yes", 1, False],
        "contact points": ["true", 1, None],
        "drag body": ["no such body", 3, None],
        "drag target (m)": [[NAN, 0.0, 0.0], [0.0, 0.0, 1e300], "abc", [1.0, 2.0], [0.1, 0.2, "0.3"]],
    }
    args = ["--preset", "so_arm100_sim_interactive", "--set", "simulation.duration=0.5"]
    with joshua_web(args, tmp_path) as run:
        page = PageClient(run.port)
        page.send("Pause", True)
        page.wait_paused()
        before = {label: len(page.sent(label)) for label in bad}
        poses = len(page.poses.get("/drag", []))
        for label, values in bad.items():
            for value in values:
                page.send(label, value)
        page.send("speed (x real time)", None, other={"max": 100.0})  # another property than the value
        page.send("time (s)", None, other={"value": "hacked"})  # a control the page alone sets
        upright, near = (1.0, 0.0, 0.0, 0.0), (0.1, 0.0, 0.2)
        bad_poses = [
            (upright, (NAN, 0.0, 0.0)),
            (upright, (0.0, 0.0, 1e300)),
            (upright, (0.1, 0.2)),
            ((0.0, 0.0, 0.0, 0.0), near),
            ((2.0, 0.0, 0.0, 0.0), near),
            ((NAN, 0.0, 0.0, 1.0), near),
        ]
        for wxyz, position in bad_poses:
            page.send_pose("/drag", wxyz, position)
        page.send("Pause", "twice")  # a button takes a click (true) only; it reads "Resume" while paused
        in_force = {"speed (x real time)": 1.0, "contact points": False, "drag body": "-", "drag target (m)": [0.0] * 3}
        for label, value in in_force.items():
            page.set_back(label, before[label], value)
        page.wait_for(lambda: ("position", [0.0, 0.0, 0.0]) in page.poses.get("/drag", [])[poses:])
        assert "hacked" not in page.sent("time (s)")
        page.send("Pause", True)  # resume: the run ends after its half simulated second, at speed 1
        err = run.finish()
        page.close()
    assert "Traceback" not in err
    for label in [*bad, "Resume", "drag gizmo"]:
        assert len(warnings_for(err, f"'{label}'")) == 1, err
    assert "ignored nan for 'speed (x real time)' (expected a number from 0.05 to 2)" in err
    assert len(warnings_for(err, "a control the page alone sets")) == 1, err


def test_passive_replay_ignores_bad_scrubs_and_ends(tmp_path: Path) -> None:
    with joshua_web(["--preset", "sim_passive"], tmp_path) as run:
        page = PageClient(run.port)
        page.send("Pause", True)
        page.wait_paused()
        page.send("scrub (s)", 1.0)  # a good one: the replay, paused, shows 1 s
        page.wait_for(lambda: "1.000" in page.sent("time (s)"))
        before = len(page.sent("scrub (s)"))
        for value in (NAN, -1e300, 1e300, -1.0, 100.0, "3", None, [1.0]):
            page.send("scrub (s)", value)
        page.set_back("scrub (s)", before, 1.0)
        duration = page.props["scrub (s)"]["max"]
        assert "1.000" in page.sent("time (s)")[-1:]
        page.send("scrub (s)", duration - 0.05)  # near the end
        page.send("Pause", True)  # resume: the replay ends
        err = run.finish()
        page.close()
    assert "Traceback" not in err
    assert len(warnings_for(err, "'scrub (s)'")) == 1, err
