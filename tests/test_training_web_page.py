"""A running training in a real headless browser, for each trainer that reads `training.web`: `joshua --preset P
--web ADDRESS` on the CPU with no X display. The page must draw several arms side by side and a return curve of at
least two points, the policy shown must change as updates arrive, and Ctrl-C then stops the training as without the
page (a checkpoint, exit 130)."""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray

pytest.importorskip("viser", reason="the training page needs viser (pip install 'joshua-render[web]')")
pytest.importorskip("selenium", reason="the browser tests need selenium")
from PIL import Image  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.wait import WebDriverWait  # noqa: E402

JOSHUA = Path(sys.executable).parent / "joshua"
STARTUP_S = 120.0  # the trainer builds its environments (and model) before the page listens (2 busy cores)
MIN_ARM_PIXELS = 150  # orange pixels of one arm at the first view's distance (about 1000 seen)
ARM_GAP_PX = 8  # columns without orange between two arms
MIN_CURVE_PIXELS = 30  # the curve's crimson stroke between two points, 2 px wide
# preset, --set overrides for a small run (stopped by the test), seconds the page may take to show two returns
TRAININGS = {
    "sb3": (
        "so_arm100_reach_sb3",
        ["training.total_timesteps=10000000", "training.num_envs=8", "training.task_config.episode_length=20"],
        90.0,  # three.js and four arms' meshes in software WebGL, then two 50-step rollouts must end
    ),
    "ppo": (
        "so_arm100_train_mjx",
        # 8 environments x 10 steps per iteration, a tiny network; episodes end within every iteration; MuJoCo Warp's
        # physics, whose iteration compiles in seconds (MJX-JAX's took about 2 minutes on 2 busy cores)
        [
            f"training.{name}={value}"
            for name, value in {
                "mjx.impl": "WARP",
                "num_envs": 8,
                "num_steps": 10,
                "num_epochs": 1,
                "minibatch_size": 40,
                "total_timesteps": 10**9,
                "task_config.episode_length": 20,
                "hidden_sizes": "[16]",
                "ppo.viewer": "OFF",
                "ppo.video_interval": -1,
            }.items()
        ],  # fmt: skip
        300.0,  # the first iteration compiles before the page shows anything (Warp's kernels too, in a cold cache)
    ),
}


def image_of(png: bytes) -> NDArray[np.uint8]:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


def arms_seen(rgb: NDArray[np.uint8]) -> int:
    """Arms in an image: runs of columns holding the SO-ARM100's orange, apart by ARM_GAP_PX, of MIN_ARM_PIXELS."""
    r, g, b = (rgb[..., i].astype(int) for i in range(3))
    per_column = np.count_nonzero((r > 150) & (r - b > 100) & (g - b > 30) & (r - g > 20), axis=0)
    arms, run, gap = 0, 0, ARM_GAP_PX
    for count in [*per_column, 0]:
        if count:
            run, gap = run + count, 0
            continue
        gap += 1
        if gap == ARM_GAP_PX:
            arms += run >= MIN_ARM_PIXELS
            run = 0
    return arms


def crimson_pixels(rgb: NDArray[np.uint8]) -> int:
    """Pixels of the return curve's stroke, rgb(220, 20, 60), anti-aliased against white."""
    r, g, b = (rgb[..., i].astype(int) for i in range(3))
    return int(np.count_nonzero((r > 180) & (g < 120) & (b < 140) & (b - g > 10)))


def shown(driver: Any, label: str) -> str:
    return driver.find_element(By.XPATH, f"//label[text()='{label}']/following::input[1]").get_attribute("value")


@pytest.fixture(params=sorted(TRAININGS))
def training(
    request: pytest.FixtureRequest, tmp_path: Path, web_run: Any
) -> Iterator[tuple[str, subprocess.Popen[str], float]]:
    pytest.importorskip(f"joshua_{request.param}", reason=f"needs the {request.param} trainer")
    preset, overrides, page_s = TRAININGS[request.param]
    env = {key: value for key, value in os.environ.items() if key not in ("DISPLAY", "WAYLAND_DISPLAY")}
    command = [str(JOSHUA), "--preset", preset, "--set", f"training.checkpoint_dir={tmp_path}"]
    command += [argument for override in overrides for argument in ("--set", override)]
    with web_run(command, cwd=tmp_path, env=env, startup_s=STARTUP_S) as (url, process):
        yield url, process, page_s


@pytest.mark.slow  # trains with a browser watching: 40-90 s on 2 cores
def test_page_shows_the_training_arms_and_the_return_curve(
    training: tuple[str, subprocess.Popen[str], float], browser: Any
) -> None:
    url, process, page_s = training
    browser.get(url)
    wait = WebDriverWait(browser, page_s, poll_frequency=0.5)
    wait.until(lambda d: arms_seen(image_of(d.get_screenshot_as_png())) >= 2)
    wait.until(lambda d: int(shown(d, "return points")) >= 2)
    first_policy = int(shown(browser, "policy after (steps)"))
    curve = browser.find_element(By.CLASS_NAME, "uplot")
    wait.until(lambda _: crimson_pixels(image_of(curve.screenshot_as_png)) >= MIN_CURVE_PIXELS)
    # the policy shown is the one being trained: it changes as updates arrive
    wait.until(lambda d: int(shown(d, "policy after (steps)")) > first_policy)
    assert process.poll() is None, "the training stopped while the browser watched"
    process.send_signal(signal.SIGINT)
    assert process.wait(timeout=60) == 130  # stopped as without the page: a checkpoint, then exit 130
