"""PASSIVE end to end from the CLI: headless it records an MP4, with a display it shows the viewer."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from modes_testing import SMALL, headless_env, orange_pixels, read_video


def test_sim_passive_headless_records_a_video_and_a_clean_report(run_joshua, tmp_path: Path) -> None:
    result = run_joshua("--preset", "sim_passive", *SMALL, "--set", "simulation.viewer.fps=10")
    assert result.returncode == 0, result.stderr
    out = tmp_path / "joshua_output"
    assert "OK: no problems" in result.stdout
    assert "recording to joshua_output/passive_replay.mp4" in result.stdout
    assert result.stdout.strip().endswith("video: joshua_output/passive_replay.mp4")
    frames, fps = read_video(out / "passive_replay.mp4")
    assert len(frames) == 62 and fps == pytest.approx(10.0)  # 6.1 s at 10 fps, both ends included
    assert frames[0].shape == (120, 160, 3) and orange_pixels(frames[30][..., ::-1]) > 50
    report = json.loads((out / "passive_report.json").read_text())
    assert report["ok"] is True and report["rows"] == report["replayed_rows"] == 3051
    assert report["joints"] == [f"joint_{i}" for i in range(1, 7)] and report["duration_s"] == pytest.approx(6.1)
    assert report["velocity_limit"] == 10.0 and report["penetration_threshold"] == 0.005


def test_tracked_replay_at_double_speed_reports_tracking_error(run_joshua, tmp_path: Path) -> None:
    result = run_joshua(
        "--preset", "sim_passive", *SMALL, "--set", "simulation.viewer.fps=5",
        "--set", "simulation.replay.tracked=true", "--set", "simulation.replay.speed=2",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "replaying 6.100 s (tracked)" in result.stdout and "tracking error (simulated - commanded)" in result.stdout
    assert len(read_video(tmp_path / "joshua_output" / "passive_replay.mp4")[0]) == 16  # 3.05 s of video at 5 fps
    tracking = json.loads((tmp_path / "joshua_output" / "passive_report.json").read_text())["tracking_error"]
    assert sorted(tracking) == [f"joint_{i}" for i in range(1, 7)]
    for error in tracking.values():  # position servos follow within a few centiradians, and never exactly
        assert 0 < error["rms"] <= error["max"] < 0.2


def test_passive_needs_a_trajectory_and_a_display_when_asked_for_the_window(run_joshua) -> None:
    missing = run_joshua("--preset", "sim_passive", "--set", "simulation.trajectory_path=")
    assert missing.returncode == 2 and "set simulation.trajectory_path to a CSV file" in missing.stderr
    window = run_joshua("--preset", "sim_passive", "--set", "simulation.viewer.display=WINDOW")
    assert window.returncode == 2
    assert "the MuJoCo viewer needs a display, but DISPLAY is not set" in window.stderr
    assert "sim_offscreen" in window.stderr and "Xvfb" in window.stderr


def test_sim_passive_with_a_display_replays_in_the_viewer(run_joshua, tmp_path: Path, xvfb: str) -> None:
    result = run_joshua(
        "--preset", "sim_passive", "--set", "simulation.replay.speed=8", "--set", "simulation.replay.loop=false",
        env=headless_env(DISPLAY=xvfb), timeout=90,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "replaying 6.100 s (kinematic): MuJoCo viewer" in result.stdout
    assert "X Error" not in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "joshua_output" / "passive_replay.mp4").exists()
    assert (tmp_path / "joshua_output" / "passive_report.json").is_file()
