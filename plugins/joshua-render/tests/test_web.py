"""The web display's address handling ([HOST:]PORT parsing, an address it cannot listen on), garbage clients, and
the training page's silence while nobody watches.

Listening and drawing in a real browser is tested in joshua-modes (tests/test_web.py).
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
import urllib.request

import numpy as np
import pytest

from joshua_core.errors import UsageError
from joshua_render.web import DEFAULT_HOST, DEFAULT_PORT, parse_web_address, start_server


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("", (DEFAULT_HOST, DEFAULT_PORT)),
        ("9000", (DEFAULT_HOST, 9000)),
        ("0.0.0.0:8081", ("0.0.0.0", 8081)),
        ("[::1]:8082", ("::1", 8082)),
        (":8083", (DEFAULT_HOST, 8083)),
    ],
)
def test_address_parsing(text: str, expected: tuple[str, int]) -> None:
    assert parse_web_address(text) == expected


@pytest.mark.parametrize("text", ["web", "host:port", "70000"])
def test_bad_address_is_a_usage_error(text: str) -> None:
    with pytest.raises(UsageError, match="web address"):
        parse_web_address(text)


def test_port_in_use_is_one_line_and_no_server(capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        assert start_server(f"127.0.0.1:{port}", title="t", instead="recording instead") is None
    err = capsys.readouterr().err
    assert err == (
        f"joshua: warning: no web display (cannot listen on 127.0.0.1:{port}: port {port} is in use); "
        "recording instead\n"
    )


def test_address_not_of_this_machine(capsys: pytest.CaptureFixture[str]) -> None:
    assert start_server("192.0.2.1:8080", title="t", instead="going on") is None  # TEST-NET-1: never local
    assert "192.0.2.1 is not an address of this machine); going on" in capsys.readouterr().err


def test_nothing_to_do_instead_is_an_error() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(UsageError, match=f"cannot listen on 127.0.0.1:{port}: port {port} is in use"):
            start_server(f"127.0.0.1:{port}", title="t", instead=None)


def test_a_client_sending_garbage_leaves_the_page_served(capfd: pytest.CaptureFixture[str]) -> None:
    """Raw bytes on the port and malformed WebSocket messages: the server keeps serving the page and the next
    client, and prints no traceback (viser drops what it cannot decode)."""
    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    server = start_server(f"127.0.0.1:{port}", title="t", instead="going on")
    assert server is not None
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=10) as raw:
            raw.sendall(b"\x00\xff\xfeGARBAGE \r\n\r\n" * 100)
        with connect(f"ws://127.0.0.1:{port}", open_timeout=30) as client:
            with contextlib.suppress(ConnectionClosed):  # the server may close on a client that makes no sense
                for message in (b"\x00\x01\x02garbage", "not a message", b"\xc1" * 1000):
                    client.send(message)
        with connect(f"ws://127.0.0.1:{port}", open_timeout=30) as client:  # the next client still connects
            with contextlib.suppress(ConnectionClosed):
                client.send(b"\x93")
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=30) as page:
            assert page.status == 200 and b"<html" in page.read().lower()
    finally:
        server.stop()
    err = capfd.readouterr().err
    assert "Traceback" not in err
    assert "joshua: warning: web display: a client sent something else than the page's protocol" in err


CAMERA_MESSAGE = {  # viser's ViewerCameraMessage as its browser client sends it
    "type": "ViewerCameraMessage",
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
SLIDER_MJCF = """<mujoco><worldbody>
  <body name="slider"><joint type="slide" axis="1 0 0"/><geom type="box" size="0.1 0.1 0.1"/></body>
</worldbody></mujoco>"""


def test_training_page_sends_poses_only_while_a_client_is_connected() -> None:
    """With nobody watching, the page's thread looks for clients and sends nothing; once one connects, the newest
    published pose is sent (the body frame moves to it). viser counts a client from its first camera message, which
    a browser sends once the page has loaded; this client sends one of its own."""
    import msgspec
    import mujoco
    import viser
    from websockets.sync.client import connect

    from joshua_render.web_training import TrainingPage

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    server = start_server(f"127.0.0.1:{port}", title="t", instead="going on")
    assert server is not None
    looks, looked_enough = [], threading.Event()
    get_clients = server.get_clients

    def counted_get_clients() -> dict[int, viser.ClientHandle]:
        clients = get_clients()
        looks.append(len(clients))
        if len(looks) >= 3:
            looked_enough.set()
        return clients

    server.get_clients = counted_get_clients  # type: ignore[method-assign]
    model = mujoco.MjModel.from_xml_string(SLIDER_MJCF)
    page = TrainingPage(server, model, envs=1)
    try:
        frame = next(iter(page._scenes[0].body_frames.values()))
        page.publish_poses(np.array([[0.3]]), policy_step=7)
        assert looked_enough.wait(timeout=30)
        assert set(looks[:3]) == {0}
        np.testing.assert_allclose(frame.position, (0.0, 0.0, 0.0), atol=1e-12)  # nothing sent to nobody
        with connect(f"ws://127.0.0.1:{port}", subprotocols=[f"viser-v{viser.__version__}"], open_timeout=30) as client:
            client.send(msgspec.msgpack.encode(CAMERA_MESSAGE))
            deadline = time.monotonic() + 30
            while not np.allclose(frame.position, (0.3, 0.0, 0.0), atol=1e-9) and time.monotonic() < deadline:
                looked_enough.clear()
                looked_enough.wait(timeout=1)  # the page's next look
            np.testing.assert_allclose(frame.position, (0.3, 0.0, 0.0), atol=1e-9)  # the slide joint's 0.3 m
    finally:
        page.close()
