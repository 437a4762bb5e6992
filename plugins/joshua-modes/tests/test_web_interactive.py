"""INTERACTIVE's web page in a real headless browser (Debian's chromium and chromedriver, driven by selenium).

`joshua --preset so_arm100_sim_interactive --web ADDRESS` holds the arm at home with no X display. The page's
body frames toggle changes the picture; dragging the fixed jaw (chosen in "drag body", its target typed into
the "drag target (m)" fields that the gizmo shares: selenium cannot find the gizmo's handles on a WebGL canvas)
moves the arm; Reset brings the time and the pose back to the start.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from modes_testing import JOSHUA_SCRIPT, click_button, headless_env, orange_mask, shown_time
from modes_testing import page_screenshot as screenshot
from numpy.typing import NDArray

pytest.importorskip("viser", reason="the web display needs viser (pip install 'joshua-render[web]')")
pytest.importorskip("selenium", reason="the browser tests need selenium")
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.common.keys import Keys  # noqa: E402
from selenium.webdriver.support.wait import WebDriverWait  # noqa: E402

STARTUP_S = 120.0  # the run starts the physics and the server first (2 busy cores)
PAGE_S = 60.0  # the page loads three.js and the model's meshes; software WebGL is slow
MIN_ARM_PIXELS = 500  # of 800x600: the arm seen whole from the first camera covers several thousand
MOVED_PIXELS = 1500  # arm pixels that must differ from the start for the arm to have moved (3400 seen when dragged)
SAME_PIXELS = 500  # at most this many differ for the same pose (230 seen: software WebGL's edges vary a little)
AXES_PIXELS = 100  # red pixels of the frames' x axes (hundreds), in the scene, not its orientation widget
FEW_PIXELS = 20
WIDGET_PX = 80  # the corner of the page's orientation widget (red, green and blue axes of its own)
LIFT_M = 0.3  # the drag target above the fixed jaw's centre of mass: the spring pulls it up by a few cm


def arm_mask(driver: Any) -> list[NDArray[np.bool_]]:
    """[where the page shows orange] once it shows the arm, else [] (the page is still loading; a notice with an
    orange edge may be there too, the same in every picture)."""
    mask = orange_mask(screenshot(driver))
    return [mask] if np.count_nonzero(mask) >= MIN_ARM_PIXELS else []


def changed(before: NDArray[np.bool_], after: NDArray[np.bool_]) -> int:
    """Pixels that differ between two arm masks."""
    return int(np.count_nonzero(before != after))


def red_pixels(rgb: NDArray[np.uint8]) -> int:
    """Pure red pixels (the body frames' x axes), outside the orientation widget at the bottom left corner."""
    r, g, b = (rgb[..., i].astype(int) for i in range(3))
    red = (r > 120) & (g < 60) & (b < 60)
    red[-WIDGET_PX:, :WIDGET_PX] = False
    return int(np.count_nonzero(red))


def target_fields(driver: Any) -> list[Any]:
    """The x, y and z inputs of "drag target (m)"."""
    return driver.find_elements(By.XPATH, "//label[text()='drag target (m)']/following::input[position() <= 3]")


@pytest.mark.slow
def test_frames_toggle_drag_and_reset(tmp_path: Path, browser: Any, web_run: Any) -> None:
    command = [str(JOSHUA_SCRIPT), "--preset", "so_arm100_sim_interactive"]
    with web_run(command, cwd=tmp_path, env=headless_env(MUJOCO_GL="egl"), startup_s=STARTUP_S) as (url, process):
        browser.get(url)
        wait = WebDriverWait(browser, PAGE_S, poll_frequency=0.2)
        wait.until(arm_mask)
        wait.until(lambda d: float(shown_time(d)) > 0.0)
        click_button(browser, "Pause")
        wait.until(lambda d: d.find_elements(By.XPATH, "//button[normalize-space()='Resume']"))
        click_button(browser, "Reset")  # the start state, in a picture of the loaded page
        wait.until(lambda d: shown_time(d) == "0.000")
        screenshot(browser)  # a pose sent with the time lands within a frame: let one pass
        start = screenshot(browser)
        home = orange_mask(start)

        # body frames: red x axes appear on the paused picture when shown, and go when hidden
        frames = browser.find_element(By.XPATH, "//label[text()='body frames']/following::input[1]")
        assert red_pixels(start) < FEW_PIXELS
        frames.click()
        wait.until(lambda d: red_pixels(screenshot(d)) >= AXES_PIXELS)
        frames.click()
        wait.until(lambda d: red_pixels(screenshot(d)) < FEW_PIXELS)

        # drag the fixed jaw: its target (the gizmo's position) raised, the spring lifts the arm
        browser.find_element(By.XPATH, "//label[text()='drag body']/following::input[1]").click()
        option = "//*[@role='option'][normalize-space()='fixed_jaw']"
        wait.until(lambda d: d.find_elements(By.XPATH, option))
        browser.find_element(By.XPATH, option).click()
        wait.until(lambda d: (field := target_fields(d)) and field[2].is_displayed())
        height = target_fields(browser)[2]
        wait.until(lambda d: float(height.get_attribute("value") or 0.0) > 0.0)  # placed at the jaw
        lifted = float(height.get_attribute("value")) + LIFT_M
        height.send_keys(Keys.CONTROL, "a")
        height.send_keys(f"{lifted:.3f}", Keys.ENTER)
        click_button(browser, "Resume")
        wait.until(lambda d: changed(home, (arm_mask(d) or [home])[0]) >= MOVED_PIXELS)

        # Reset: back to the keyframe at time 0, the drag released (paused, so the time stays there)
        click_button(browser, "Pause")
        wait.until(lambda d: d.find_elements(By.XPATH, "//button[normalize-space()='Resume']"))
        assert shown_time(browser) != "0.000"  # else the check below could not fail
        click_button(browser, "Reset")
        wait.until(lambda d: shown_time(d) == "0.000")
        wait.until(lambda d: changed(home, (arm_mask(d) or [~home])[0]) < SAME_PIXELS)
        assert (
            browser.find_element(By.XPATH, "//label[text()='drag body']/following::input[1]").get_attribute("value")
            == "-"
        )
        assert process.poll() is None, "the simulation stopped while the browser watched"
