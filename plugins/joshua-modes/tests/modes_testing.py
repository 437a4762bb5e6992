"""Plain helpers of the joshua-modes tests: paths, small trajectories, video decoding, colour counts, web pages."""

from __future__ import annotations

import io
import os
import sys
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray
from PIL import Image

from joshua_core.resources import models_dir

JOSHUA_SCRIPT = Path(sys.executable).parent / "joshua"
EXAMPLE_CSV = models_dir() / "trajectories" / "so_arm100_example.csv"
SCENE = models_dir() / "so_arm100" / "scene.xml"
HEADER = "timestamp,joint_1,joint_2,joint_3,joint_4,joint_5,joint_6"
SMALL = ("--set", "simulation.render_width=160", "--set", "simulation.render_height=120")


def headless_env(**extra: str) -> dict[str, str]:
    """This environment without a display and without the GL choice this test process made, plus `extra`."""
    dropped = ("DISPLAY", "WAYLAND_DISPLAY", "MUJOCO_GL", "PYOPENGL_PLATFORM")
    env = {key: value for key, value in os.environ.items() if key not in dropped}
    return {**env, **extra}


def example_rows(seconds: float) -> list[str]:
    """Data rows of the example trajectory up to `seconds`."""
    rows = [line for line in EXAMPLE_CSV.read_text().splitlines() if line and line[0].isdigit()]
    return [row for row in rows if float(row.split(",")[0]) <= seconds + 1e-9]


def read_video(path: Path) -> tuple[list[NDArray[np.uint8]], float]:
    """Every frame (BGR) of a video file and its frame rate, read back with OpenCV."""
    capture = cv2.VideoCapture(str(path))
    assert capture.isOpened(), f"OpenCV cannot open {path}"
    fps = capture.get(cv2.CAP_PROP_FPS)
    frames = []
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        frames.append(frame)
    capture.release()
    return frames, fps


def distinct_colours(image: NDArray[np.uint8]) -> int:
    return len(np.unique(image.reshape(-1, image.shape[-1]), axis=0))


def orange_mask(rgb: NDArray[np.uint8]) -> NDArray[np.bool_]:
    """Where the SO-ARM100's printed parts (material 'printed', orange) are, lit or shaded."""
    r, g, b = (rgb[..., i].astype(int) for i in range(3))
    return (r > 150) & (r - b > 100) & (g - b > 30) & (r - g > 20)


def orange_pixels(rgb: NDArray[np.uint8]) -> int:
    """How many pixels show the SO-ARM100's printed parts."""
    return int(np.count_nonzero(orange_mask(rgb)))


def page_screenshot(driver: Any) -> NDArray[np.uint8]:
    """What a selenium-driven browser shows, as RGB."""
    return np.asarray(Image.open(io.BytesIO(driver.get_screenshot_as_png())).convert("RGB"))


def shown_time(driver: Any) -> str:
    """The simulation time a web display's page shows (the panel's 'time (s)' field)."""
    return driver.find_element("xpath", "//label[text()='time (s)']/following::input[1]").get_attribute("value")


def click_button(driver: Any, text: str) -> None:
    """Click the page's button labelled `text`."""
    driver.find_element("xpath", f"//button[normalize-space()='{text}']").click()
