"""MIRROR in a real headless browser: `joshua --preset sim_mirror --web ADDRESS` with no X display, fed by a real
ROS 2 publisher on loopback. The page must draw the orange arm, move it when the encoders do, and show the topics'
status: stale joints, the tracking error and a topic published with the wrong message type.
"""

from __future__ import annotations

import io
import json
import re
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray

pytest.importorskip("viser", reason="the web display needs viser (pip install 'joshua-render[web]')")
pytest.importorskip("selenium", reason="the browser tests need selenium")
from PIL import Image  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.wait import WebDriverWait  # noqa: E402

JOSHUA = Path(sys.executable).parent / "joshua"
PUBLISHER = Path(__file__).with_name("publisher.py")
STARTUP_S = 120.0  # the mirror starts ROS and the server first (2 busy cores)
PAGE_S = 60.0  # the page loads three.js and the model's meshes; software WebGL is slow
MIN_ARM_PIXELS = 500  # of 800x600: the arm seen whole from the first camera covers several thousand
MOVED_PIXELS = 200  # pixels that must differ between the start pose and the mirrored one
POSE = {"joint_1": 0.6, "joint_2": -0.5, "joint_3": 0.8, "joint_4": 0.3, "joint_5": 0.2}  # joint_6 never comes
WRONG_TOPIC = "/encoder/joint_6"  # published as std_msgs/Float32, which the mirror (Float64) never receives


def orange_pixels(rgb: NDArray[np.uint8]) -> int:
    """Pixels of the SO-ARM100's printed parts (material 'printed', orange), lit or shaded."""
    r, g, b = (rgb[..., i].astype(int) for i in range(3))
    return int(np.count_nonzero((r > 150) & (r - b > 100) & (g - b > 30) & (r - g > 20)))


def page_image(driver: Any) -> NDArray[np.uint8]:
    return np.asarray(Image.open(io.BytesIO(driver.get_screenshot_as_png())).convert("RGB"))


def arm_image(driver: Any) -> list[NDArray[np.uint8]]:
    """[a screenshot] if it shows the orange arm, else [] (the page is still loading; an array has no truth)."""
    image = page_image(driver)
    return [image] if orange_pixels(image) >= MIN_ARM_PIXELS else []


def page_text(driver: Any) -> str:
    return driver.find_element(By.TAG_NAME, "body").text


@pytest.fixture
def mirror_url(tmp_path: Path, ros_env: dict[str, str], web_run: Any) -> Iterator[str]:
    """The mirror (tracking through the actuators) in a web page, without an X display; yields its URL."""
    env = {key: value for key, value in ros_env.items() if key not in ("DISPLAY", "WAYLAND_DISPLAY", "MUJOCO_GL")}
    command = [str(JOSHUA), "--preset", "sim_mirror"]
    for override in ("simulation.mirror.apply=ACTUATOR", "simulation.mirror.status_period=0.2"):
        command += ["--set", override]
    with web_run(command, cwd=tmp_path, env={**env, "MUJOCO_GL": "egl"}, startup_s=STARTUP_S) as (url, process):
        yield url
        assert process.poll() is None, "the mirror stopped while the browser watched"


def publish(env: dict[str, str], plan: dict[str, Any]) -> None:
    result = subprocess.run(
        [sys.executable, str(PUBLISHER), json.dumps(plan)], env=env, capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0, result.stderr


@pytest.mark.slow  # a mirror, a publisher and a browser: 35 s on 2 cores; the passive page test stays fast
def test_page_shows_the_mirrored_arm_and_the_topics_status(
    mirror_url: str, browser: Any, ros_env: dict[str, str], hold_publishers: Callable[..., subprocess.Popen[str]]
) -> None:
    browser.get(mirror_url)
    wait = WebDriverWait(browser, PAGE_S, poll_frequency=0.2)
    (start,) = wait.until(arm_image)
    # nothing published yet: every joint is stale, said in the page
    wait.until(lambda d: page_text(d).count("STALE") == 6)
    assert "tracking error: no sample yet" in page_text(browser)

    hold_publishers(ros_env, [{"topic": WRONG_TOPIC, "type": "Float32", "value": 0.1}])
    hold = [{"topic": f"/encoder/{joint}", "value": value} for joint, value in POSE.items()]
    publish(ros_env, {"wait_for": "/encoder/joint_1", "messages": [*hold, {"sleep": 0.05}] * 10})

    # the arm moved to the published pose, and the page says how well the twin follows it
    wait.until(lambda d: np.count_nonzero(np.any(page_image(d) != start, axis=-1)) >= MOVED_PIXELS)
    wait.until(lambda d: f"WRONG TYPE {WRONG_TOPIC}: published as std_msgs/msg/Float32" in page_text(d))
    text = page_text(browser)
    pattern = r"joint_(\d) \(/encoder/joint_\d\): ([-+.\d]+), \d+ ms ago(?: STALE)?, tracking error RMS ([.\d]+)"
    errors = re.findall(pattern, text)
    assert {joint for joint, _, _ in errors} == {"1", "2", "3", "4", "5"}, text
    for joint, value, _ in errors:  # the page's value is the last published, to its three decimals
        assert abs(float(value) - POSE[f"joint_{joint}"]) < 5e-4
    assert "joint_6 (/encoder/joint_6): no value yet STALE" in text
