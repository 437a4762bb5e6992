"""OFFSCREEN: run_offscreen, the streaming form, the mode's files, and the error when no GL platform works.

The choice of GL platform itself is tested with joshua-render, which makes it."""

from __future__ import annotations

import json
import types
from pathlib import Path

import av
import cv2
import numpy as np
import pytest
from modes_testing import HEADER, SCENE, SMALL, distinct_colours, example_rows, headless_env, orange_pixels, read_video

from joshua_core.plugins import PluginHost
from joshua_modes.offscreen import FrameRenderer, iter_offscreen_frames, run_offscreen
from joshua_mujoco import MuJoCoEngine


@pytest.fixture
def short_csv(write_csv) -> Path:
    return write_csv([HEADER, *example_rows(2.0)])  # the arm's first reach: 2 s


def test_run_offscreen_returns_frames_of_the_moving_arm(short_csv: Path) -> None:
    frames = run_offscreen(model_path=str(SCENE), trajectory_path=str(short_csv), width=160, height=120)
    assert len(frames) == 61  # 2 s at 30 fps, both ends included
    assert all(frame.shape == (120, 160, 3) and frame.dtype == np.uint8 for frame in frames)
    assert distinct_colours(frames[0]) > 300 and orange_pixels(frames[0]) > 50
    motion = [np.abs(frames[i].astype(int) - frames[0]).mean() for i in (0, 30, 60)]
    assert motion[0] == 0 and motion[2] > motion[1] > 0.5  # the arm moves away from its start pose


def test_streaming_form_is_lazy_and_matches(short_csv: Path) -> None:
    stream = iter_offscreen_frames(SCENE, short_csv, 160, 120, fps=5, plugins=PluginHost.discover())
    assert isinstance(stream, types.GeneratorType)
    first = next(stream)
    rest = list(stream)
    assert len(rest) == 10  # 2 s at 5 fps: 11 frames
    listed = run_offscreen(SCENE, short_csv, 160, 120, fps=5)
    np.testing.assert_array_equal(listed[0], first)
    np.testing.assert_array_equal(listed[-1], rest[-1])


def test_cameras_shadows_depth_and_segmentation() -> None:
    with MuJoCoEngine(SCENE) as engine:
        engine.reset("home")
        overview = FrameRenderer(engine.model, 160, 120, camera="overview")
        side = FrameRenderer(engine.model, 160, 120, camera="side")
        flat = FrameRenderer(engine.model, 160, 120, camera="overview", shadows=False)
        try:
            image = overview.rgb(engine.data)
            assert np.abs(image.astype(int) - side.rgb(engine.data)).mean() > 5
            assert np.abs(image.astype(int) - flat.rgb(engine.data)).mean() > 0.5  # shadows change the picture
            depth = overview.depth_mm(engine.data)
            assert depth.dtype == np.uint16 and depth.shape == (120, 160)
            assert 100 < np.median(depth) < 5000  # the table and arm are decimetres to metres away
            segmentation = overview.segmentation(engine.data)
            geoms = [int(i) - 1 for i in np.unique(segmentation) if i]
            bodies = {engine.model.body(engine.model.geom_bodyid[geom]).name for geom in geoms}
            assert "table_top_visual" in {engine.model.geom(geom).name for geom in geoms}
            assert {"base", "upper_arm", "forearm"} <= bodies
            again = overview.rgb(engine.data)  # depth/segmentation modes switched back off: colour again
            assert again.shape == (120, 160, 3) and np.abs(again.astype(int) - image).mean() < 1
        finally:
            for renderer in (overview, side, flat):
                renderer.close()


def test_sim_offscreen_preset_writes_video_png_depth_segmentation(run_joshua, tmp_path: Path) -> None:
    result = run_joshua(
        "--preset", "sim_offscreen", *SMALL,
        "--set", "simulation.offscreen.fps=4",
        "--set", "simulation.offscreen.output=MP4_AND_PNG",
        "--set", "simulation.offscreen.depth=true",
        "--set", "simulation.offscreen.segmentation=true",
        "--set", "simulation.offscreen.camera=side",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    out = tmp_path / "joshua_output"
    frames, fps = read_video(out / "offscreen.mp4")
    assert len(frames) == 25 and fps == pytest.approx(4.0)  # 6.1 s at 4 fps
    assert frames[0].shape == (120, 160, 3) and orange_pixels(frames[12][..., ::-1]) > 50
    pngs = sorted((out / "offscreen_frames").glob("*.png"))
    assert len(pngs) == 25 and pngs[0].name == "frame_000000.png"
    png = cv2.imread(str(pngs[12]))[..., ::-1]
    assert png.shape == (120, 160, 3) and distinct_colours(png) > 300
    with av.open(str(out / "offscreen.mp4")) as container:  # H.264 in yuv420p: the MP4 that browsers play
        codec = container.streams.video[0].codec_context
        assert (codec.name, codec.format.name) == ("h264", "yuv420p")
    assert np.abs(frames[12][..., ::-1].astype(int) - png).mean() < 8  # the video's frame is the PNG, lossily
    depth = cv2.imread(str(out / "offscreen_depth" / "frame_000012.png"), cv2.IMREAD_UNCHANGED)
    assert depth.dtype == np.uint16 and 100 < depth.min() < 2000 and depth.max() > depth.min() + 200
    segmentation = cv2.imread(str(out / "offscreen_segmentation" / "frame_000012.png"), cv2.IMREAD_UNCHANGED)
    assert segmentation.dtype == np.uint16 and len(np.unique(segmentation)) > 5
    report = json.loads((out / "offscreen_report.json").read_text())
    assert report["ok"] is True and report["rows"] == 3051 and report["issues"] == []
    assert "rendered 25 frames of 160x120 at 4 fps" in result.stdout


def test_offscreen_without_trajectory_renders_the_physics(run_joshua, tmp_path: Path) -> None:
    result = run_joshua(
        "--preset", "sim_offscreen", *SMALL, "--set", "simulation.trajectory_path=",
        "--set", "simulation.duration=1", "--set", "simulation.offscreen.fps=10",
        "--set", "simulation.keyframe=home", "--set", "simulation.offscreen.shadows=false",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert len(read_video(tmp_path / "joshua_output" / "offscreen.mp4")[0]) == 11


def test_unknown_camera_is_a_usage_error(run_joshua) -> None:
    result = run_joshua("--preset", "sim_offscreen", *SMALL, "--set", "simulation.offscreen.camera=top")
    assert result.returncode == 2
    assert result.stderr.strip() == "joshua: error: no camera 'top' in the model; cameras: overview, side"


def test_no_working_gl_names_the_debian_packages(run_joshua) -> None:
    result = run_joshua(
        "--preset", "sim_offscreen", *SMALL,
        env=headless_env(MUJOCO_GL="egl", __EGL_VENDOR_LIBRARY_FILENAMES="/nonexistent/egl_vendor.json"),
    )  # fmt: skip
    assert result.returncode == 1
    assert "Traceback" not in result.stderr
    message = result.stderr.strip().splitlines()[-1]
    assert message.startswith("joshua: error: rendering failed with MUJOCO_GL=egl")
    assert "libegl1 libgl1-mesa-dri libopengl0" in message and "libosmesa6" in message


def test_too_many_frames_is_a_usage_error_before_any_allocation(run_joshua, tmp_path: Path) -> None:
    """duration and fps each within bounds, their product 3e10 frames: refused, not a 240 GB np.arange."""
    args = ("--preset", "sim_offscreen", "--set", "simulation.trajectory_path=", "--set", "simulation.duration=1e9")
    result = run_joshua(*args)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "1e+09 s at 30 frames per second of replayed time is 3e+10 frames, more than 10,000,000" in result.stderr
    assert not (tmp_path / "joshua_output" / "offscreen.mp4").exists()
