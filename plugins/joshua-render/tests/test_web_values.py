"""A page that takes no value from browsers (a training's) ignores one a client sends to any of its controls: the
value shown stays, the terminal gets one line, no traceback. The checks of the controls that do take values are
tested against real runs in joshua-modes (tests/test_web_inputs.py)."""

from __future__ import annotations

import threading

import pytest

from joshua_render.web import start_server

pytest.importorskip("viser", reason="the web display needs viser (pip install 'joshua-render[web]')")

SLIDER_MJCF = """<mujoco><worldbody>
  <body name="slider"><joint type="slide" axis="1 0 0"/><geom type="box" size="0.1 0.1 0.1"/></body>
</worldbody></mujoco>"""
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
WARNING = "joshua: warning: web display: ignored 'hacked' for a control the page alone sets"


def test_training_page_takes_no_value_from_a_browser(capfd: pytest.CaptureFixture[str]) -> None:
    """The values, then a camera message: viser handles a client's messages in order, so once the camera message
    counted the client, the values were handled."""
    import msgspec
    import mujoco
    import viser
    from websockets.sync.client import connect

    from joshua_render.web_training import TrainingPage

    server = start_server("127.0.0.1:0", title="t", instead="going on")
    assert server is not None
    page = TrainingPage(server, mujoco.MjModel.from_xml_string(SLIDER_MJCF), envs=1)
    counted = threading.Event()
    server.on_client_connect(lambda _: counted.set())
    policy = page._policy
    try:
        with connect(
            f"ws://127.0.0.1:{server.get_port()}", subprotocols=[f"viser-v{viser.__version__}"], open_timeout=30
        ) as client:
            for value in ("hacked", 5, None, [1, 2]):
                update = {"type": "GuiUpdateMessage", "uuid": policy._impl.uuid, "updates": {"value": value}}
                client.send(msgspec.msgpack.encode(update))
            client.send(msgspec.msgpack.encode(CAMERA_MESSAGE))
            assert counted.wait(timeout=30)
        assert policy.value == "0"
    finally:
        page.close()
    err = capfd.readouterr().err
    assert "Traceback" not in err
    assert [line for line in err.splitlines() if line.startswith("joshua: warning:")] == [WARNING]
