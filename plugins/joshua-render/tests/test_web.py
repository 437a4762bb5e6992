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
    published pose is sent (the body frame moves to it), then the return curve and the count of blown-up episodes.
    viser counts a client from its first camera message, which a browser sends once the page has loaded; this client
    sends one of its own."""
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
            page.publish_return(10, 1.0, failed_episodes=3)
            page.publish_return(20, 2.0, failed_episodes=2)
            deadline = time.monotonic() + 30
            while page._blown_up.value != "5" and time.monotonic() < deadline:
                looked_enough.clear()
                looked_enough.wait(timeout=1)
            assert page._blown_up.value == "5"  # the run's blown-up episodes, summed over the updates
            assert page._points.value == "2"
    finally:
        page.close()


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _status_of(url: str, headers: dict[str, str]) -> tuple[int, dict[str, str]]:
    """The status and headers a plain HTTP GET gets (a refusal's 403 included)."""
    import urllib.error

    try:
        with urllib.request.urlopen(urllib.request.Request(url, headers=headers), timeout=30) as page:
            return page.status, dict(page.headers)
    except urllib.error.HTTPError as error:
        return error.code, dict(error.headers)


def _handshake_status(port: int, host: str, *, origin: str) -> int:
    """The status a WebSocket handshake naming `host` (as a page on a rebound name would) gets: 101 is accepted."""
    import base64
    import os

    request = (
        f"GET / HTTP/1.1\r\nHost: {host}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nOrigin: {origin}\r\n"
        f"Sec-WebSocket-Key: {base64.b64encode(os.urandom(16)).decode()}\r\nSec-WebSocket-Version: 13\r\n\r\n"
    )
    with socket.create_connection(("127.0.0.1", port), timeout=30) as raw:
        raw.sendall(request.encode())
        reply = b""
        while b"\r\n" not in reply:
            chunk = raw.recv(4096)
            assert chunk, reply
            reply += chunk
    return int(reply.split(b" ")[1])


def test_a_foreign_web_site_cannot_drive_the_page(capfd: pytest.CaptureFixture[str]) -> None:
    """A WebSocket opened by another web site (its Origin), from a sandboxed frame (`Origin: null`) or through a
    rebound host name (its Host) is refused with 403 before viser sees it, and said once on the terminal; the
    page's own origin and a program sending no Origin are let in."""
    import viser
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    port = _free_port()
    server = start_server(f"127.0.0.1:{port}", title="t", instead="going on")
    assert server is not None
    own = f"http://127.0.0.1:{port}"
    protocol = [f"viser-v{viser.__version__}"]
    try:
        for origin in ("https://evil.example", "null", f"http://127.0.0.1:{port + 1}"):
            with pytest.raises(InvalidStatus) as refused:
                connect(f"ws://127.0.0.1:{port}", origin=origin, subprotocols=protocol, open_timeout=30)
            assert refused.value.response.status_code == 403
        assert _handshake_status(port, f"evil.example:{port}", origin=f"http://evil.example:{port}") == 403
        assert _handshake_status(port, f"127.0.0.1:{port}", origin=own) == 101  # the same handshake from the page
        assert _status_of(f"{own}/", {"Host": f"evil.example:{port}"})[0] == 403
        assert _status_of(f"{own}/", {"Origin": "https://evil.example"})[0] == 403
        assert _handshake_status(port, f"localhost:{port}", origin=f"http://localhost:{port}") == 101
        with connect(f"ws://127.0.0.1:{port}", origin=own, subprotocols=protocol, open_timeout=30) as client:
            assert client.subprotocol == protocol[0]
        with connect(f"ws://127.0.0.1:{port}", subprotocols=protocol, open_timeout=30) as client:
            assert client.subprotocol == protocol[0]
        assert _status_of(f"{own}/", {"Origin": own})[0] == 200
    finally:
        server.stop()
    err = capfd.readouterr().err
    assert "Traceback" not in err
    assert err.count("joshua: warning: web display: refused a request: Origin 'https://evil.example'") == 1
    assert "refused a request: Origin 'null' is not the page's own" in err
    assert f"refused a request: Host 'evil.example:{port}' is not this server" in err


def test_a_page_reachable_from_the_network_asks_for_the_printed_token(capfd: pytest.CaptureFixture[str]) -> None:
    """On a network address the terminal prints the URL with a token; without it (or with another) every request
    is refused, with it the page answers and sets the cookie its scripts and WebSocket then carry."""
    import viser
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    port = _free_port()
    server = start_server(f"0.0.0.0:{port}", title="t", instead="going on")
    assert server is not None
    try:
        printed = capfd.readouterr().out
        assert f"web display: http://0.0.0.0:{port}/?token=" in printed
        assert "(reachable from the network; the token is needed)" in printed
        token = printed.split("?token=")[1].split()[0]
        base = f"http://127.0.0.1:{port}/"
        assert _status_of(base, {})[0] == 403
        assert _status_of(f"{base}?token=wrong", {})[0] == 403
        status, headers = _status_of(f"{base}?token={token}", {})
        assert status == 200
        assert headers["Set-Cookie"].startswith(f"joshua_web_token={token};")
        assert "HttpOnly" in headers["Set-Cookie"] and "SameSite=Strict" in headers["Set-Cookie"]
        protocol = [f"viser-v{viser.__version__}"]
        with pytest.raises(InvalidStatus) as refused:
            connect(f"ws://127.0.0.1:{port}", additional_headers={"Cookie": "joshua_web_token=wrong"},
                    subprotocols=protocol, open_timeout=30)  # fmt: skip
        assert refused.value.response.status_code == 403
        with connect(f"ws://127.0.0.1:{port}", additional_headers={"Cookie": f"joshua_web_token={token}"},
                     origin=f"http://127.0.0.1:{port}", subprotocols=protocol, open_timeout=30) as client:  # fmt: skip
            assert client.subprotocol == protocol[0]
    finally:
        server.stop()
    assert "refused a request: no valid token (open the address the terminal printed)" in capfd.readouterr().err
