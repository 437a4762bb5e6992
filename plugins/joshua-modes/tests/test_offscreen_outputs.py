"""OFFSCREEN outputs are never mixed or left half-written: a re-render replaces the PNG folders whole, a render
stopped by SIGINT or SIGTERM (or killed, then run again) leaves no temporary files behind, and one killed part
way leaves the earlier render's report, video and frames together."""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import time
from pathlib import Path

import cv2
import pytest
from modes_testing import JOSHUA_SCRIPT, SMALL, headless_env

PNG = ("--preset", "sim_offscreen", "--set", "simulation.offscreen.output=PNG")


def frames_of(out: Path) -> list[tuple[str, tuple[int, ...]]]:
    """(name, shape) of each PNG in the frames folder."""
    pngs = sorted((out / "offscreen_frames").glob("*.png"))
    return [(png.name, cv2.imread(str(png)).shape) for png in pngs]


def temporaries(out: Path) -> list[str]:
    """The hidden files and folders in the output folder: temporaries of outputs being written."""
    return sorted(path.name for path in out.iterdir() if path.name.startswith("."))


def test_a_shorter_smaller_render_replaces_the_frames(run_joshua, tmp_path: Path) -> None:
    first = run_joshua(*PNG, *SMALL, "--set", "simulation.offscreen.fps=4")
    assert first.returncode == 0, first.stderr
    out = tmp_path / "joshua_output"
    assert len(frames_of(out)) == 25
    second = run_joshua(
        *PNG, "--set", "simulation.render_width=80", "--set", "simulation.render_height=60",
        "--set", "simulation.offscreen.fps=2",
    )  # fmt: skip
    assert second.returncode == 0, second.stderr
    frames = frames_of(out)
    assert [name for name, _ in frames] == [f"frame_{index:06d}.png" for index in range(13)]
    assert {shape for _, shape in frames} == {(60, 80, 3)} and temporaries(out) == []
    umask = os.umask(0o022)
    os.umask(umask)
    assert stat.S_IMODE((out / "offscreen_frames").stat().st_mode) == 0o777 & ~umask  # a plain mkdir's, not 0700


def start_long_render(tmp_path: Path) -> tuple[subprocess.Popen[str], Path]:
    """A render of thousands of frames to MP4 and PNG, returned once it has written some of both."""
    process = subprocess.Popen(
        [str(JOSHUA_SCRIPT), "--preset", "sim_offscreen", *SMALL, "--set", "simulation.offscreen.fps=500",
         "--set", "simulation.offscreen.output=MP4_AND_PNG"],
        cwd=tmp_path, env=headless_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    out = tmp_path / "joshua_output"
    deadline = time.monotonic() + 120
    while process.poll() is None and time.monotonic() < deadline:
        staged = [out / name for name in temporaries(out)] if out.is_dir() else []  # where this render writes
        video = [path for folder in staged for path in folder.glob(".offscreen.mp4.*.tmp.mp4")]
        if video and any(path for folder in staged for path in folder.glob("offscreen_frames/*.png")):
            return process, out
        time.sleep(0.05)
    process.kill()
    raise AssertionError(f"the render wrote no temporary video and frames: {process.communicate()}")


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signalled_render_leaves_no_temporaries_and_the_old_frames(run_joshua, tmp_path: Path, signum: int) -> None:
    before = run_joshua(*PNG, *SMALL, "--set", "simulation.offscreen.fps=2")
    assert before.returncode == 0, before.stderr
    process, out = start_long_render(tmp_path)
    process.send_signal(signum)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 128 + signum and "Traceback" not in stderr, stderr[-2000:]
    assert temporaries(out) == []
    assert len(frames_of(out)) == 13  # the previous render's frames, not a mix
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_the_next_render_removes_what_a_killed_one_left(run_joshua, tmp_path: Path) -> None:
    process, out = start_long_render(tmp_path)
    process.send_signal(signal.SIGKILL)
    process.communicate(timeout=60)
    assert temporaries(out) != []  # SIGKILL cannot be caught
    both = ("--set", "simulation.offscreen.output=MP4_AND_PNG")
    after = run_joshua(*PNG, *SMALL, "--set", "simulation.offscreen.fps=2", *both)
    assert after.returncode == 0, after.stderr
    assert temporaries(out) == [] and len(frames_of(out)) == 13


def test_a_render_killed_part_way_leaves_the_earlier_outputs_together(run_joshua, tmp_path: Path) -> None:
    """Render A (report, video, frames), then kill render B once it has written frames: A's report, video and
    frames are all still there, unchanged byte for byte, and nothing of B is among them."""
    first = run_joshua(*PNG, *SMALL, "--set", "simulation.offscreen.fps=2", "--set",
                       "simulation.offscreen.output=MP4_AND_PNG")  # fmt: skip
    assert first.returncode == 0, first.stderr
    out = tmp_path / "joshua_output"
    earlier = {path.relative_to(out): path.read_bytes() for path in out.rglob("*") if path.is_file()}
    assert {Path("offscreen_report.json"), Path("offscreen.mp4")} <= set(earlier) and len(frames_of(out)) == 13
    process, _ = start_long_render(tmp_path)
    process.send_signal(signal.SIGKILL)
    process.communicate(timeout=60)
    now = {path.relative_to(out): path.read_bytes() for path in out.rglob("*") if path.is_file()}
    staged = {path for path in now if path.parts[0].startswith(".")}
    assert staged and {path: now[path] for path in set(now) - staged} == earlier
