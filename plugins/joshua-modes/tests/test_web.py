"""The web display in a real headless browser (Debian's chromium and chromedriver, driven by selenium).

`joshua --preset sim_passive --web ADDRESS` runs with no X display; the page must draw the orange arm,
its image must change as the replay moves, and a click on Pause must stop the replay's time. A trajectory's
problems are listed with their replay times and marked at those times on the time slider.
"""

from __future__ import annotations

import contextlib
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from modes_testing import HEADER, JOSHUA_SCRIPT, click_button, headless_env, orange_pixels, shown_time
from modes_testing import page_screenshot as screenshot
from numpy.typing import NDArray

pytest.importorskip("viser", reason="the web display needs viser (pip install 'joshua-render[web]')")
pytest.importorskip("selenium", reason="the browser tests need selenium")
from selenium import webdriver  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.wait import WebDriverWait  # noqa: E402

CHROMEDRIVER = shutil.which("chromedriver")
pytestmark = pytest.mark.skipif(CHROMEDRIVER is None, reason="needs chromium and chromedriver (apt-get install)")

STARTUP_S = 120.0  # the run validates the trajectory and starts the server first (2 busy cores)
PAGE_S = 60.0  # the page loads three.js and the model's meshes; software WebGL is slow
MIN_ARM_PIXELS = 500  # of 800x600: the arm seen whole from the first camera covers several thousand
MOVED_PIXELS = 200  # pixels that must differ between two images of the moving arm


@contextlib.contextmanager
def web_replay(web_run: Any, folder: Path, *overrides: str) -> Iterator[str]:
    """A PASSIVE replay in a web page (the `web_run` fixture), run in `folder` with `--set` `overrides`; yields
    its URL."""
    command = [str(JOSHUA_SCRIPT), "--preset", "sim_passive"]
    command += [argument for override in overrides for argument in ("--set", override)]
    with web_run(command, cwd=folder, env=headless_env(MUJOCO_GL="egl"), startup_s=STARTUP_S) as (url, process):
        yield url
        assert process.poll() is None, "the replay stopped while the browser watched"


@pytest.fixture
def replay_url(tmp_path: Path, web_run: Any) -> Iterator[str]:
    """A looping, slowed-down PASSIVE replay of the example trajectory in a web page; yields its URL."""
    with web_replay(web_run, tmp_path, "simulation.replay.loop=true", "simulation.replay.speed=0.5") as url:
        yield url


def arm_image(driver: webdriver.Chrome) -> list[NDArray[np.uint8]]:
    """[a screenshot] if it shows the orange arm, else [] (the page is still loading)."""
    image = screenshot(driver)
    return [image] if orange_pixels(image) >= MIN_ARM_PIXELS else []


@pytest.mark.slow
def test_page_draws_the_moving_arm_and_pause_stops_time(replay_url: str, browser: webdriver.Chrome) -> None:
    browser.get(replay_url)
    wait = WebDriverWait(browser, PAGE_S, poll_frequency=0.2)
    (first,) = wait.until(arm_image)
    # the replay moves the arm: a later image differs where the arm is
    wait.until(lambda d: np.count_nonzero(np.any(screenshot(d) != first, axis=-1)) >= MOVED_PIXELS)
    wait.until(lambda d: float(shown_time(d)) > 0.0)

    click_button(browser, "Pause")
    wait.until(lambda d: d.find_elements(By.XPATH, "//button[normalize-space()='Resume']"))
    screenshot(browser)  # a pose sent just before the click lands within a frame: let one pass
    paused_at = shown_time(browser)
    still = screenshot(browser)
    for _ in range(5):  # each screenshot takes a software-rendered frame: time passes between them
        assert shown_time(browser) == paused_at
        assert np.count_nonzero(np.any(screenshot(browser) != still, axis=-1)) < MOVED_PIXELS

    click_button(browser, "Resume")  # and time goes on again: the checks above can fail
    wait.until(lambda d: shown_time(d) != paused_at)


@pytest.mark.slow
def test_page_lists_the_problems_with_their_times_marks_them_and_goes_to_them(
    tmp_path: Path, browser: webdriver.Chrome, web_run: Any
) -> None:
    home = "-0.35,0.35,1.0,0.0,0.4"  # joints 2 to 6
    rows = [f"{t},0.0,{home}" for t in ("0.0", "0.5")] + [f"1.0,2.0,{home}"]  # joint_1 beyond 1.92 at 1 s
    trajectory = tmp_path / "motion.csv"
    trajectory.write_text("\n".join([HEADER, *rows, *(f"{t},0.0,{home}" for t in ("1.5", "2.0"))]) + "\n")
    with web_replay(
        web_run, tmp_path, f"simulation.trajectory_path={trajectory}", "simulation.replay.loop=true"
    ) as url:
        browser.get(url)
        wait = WebDriverWait(browser, PAGE_S, poll_frequency=0.2)
        problem = "#1 at 1.000 s: motion.csv:4: joint_1 outside its range [-1.92, 1.92]: 2 at line 4"
        wait.until(lambda d: problem in d.find_element(By.TAG_NAME, "body").text)
        labels = {label.text: label for label in browser.find_elements(By.CLASS_NAME, "mantine-Slider-markLabel")}
        assert set(labels) == {"0", "#1", "2"}, sorted(labels)
        # the mark stands where 1 s of the 2 s replay is on the slider: halfway between the ends' marks
        centre = {text: label.rect["x"] + label.rect["width"] / 2 for text, label in labels.items()}
        halfway = (centre["0"] + centre["2"]) / 2
        assert abs(centre["#1"] - halfway) <= 0.02 * (centre["2"] - centre["0"]), centre
        # choosing the mark in the "go to" list moves the paused replay to it
        wait.until(lambda d: float(shown_time(d)) >= 1.5)  # past the mark (the replay loops over 2 s)
        click_button(browser, "Pause")
        wait.until(lambda d: d.find_elements(By.XPATH, "//button[normalize-space()='Resume']"))
        assert shown_time(browser) != "1.000"  # else the check below could not fail
        browser.find_element(By.XPATH, "//label[text()='go to']/following::input[1]").click()
        wait.until(lambda d: d.find_elements(By.XPATH, "//*[@role='option'][normalize-space()='#1 at 1.000 s']"))
        browser.find_element(By.XPATH, "//*[@role='option'][normalize-space()='#1 at 1.000 s']").click()
        wait.until(lambda d: shown_time(d) == "1.000")
