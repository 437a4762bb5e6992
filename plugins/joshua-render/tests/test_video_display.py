"""VideoWriter and open_display (the contract the modes and the mirror use): real MP4 files decoded with PyAV
(the stream browsers get: H.264, yuv420p, index first) and read back with OpenCV.

The engine is the tests' own minimal `Engine` (render_testing.SceneEngine): any engine with MuJoCo's model and
data can be shown or recorded, not only the MuJoCo backend's."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from fractions import Fraction
from pathlib import Path
from typing import Any

import av
import numpy as np
import pytest
from render_testing import SceneEngine, distinct_colours, orange_pixels, read_video

from joshua_core.errors import JoshuaError, UsageError
from joshua_render import RecordingDisplay, VideoWriter, open_display


def gradient(index: int, height: int = 48, width: int = 64) -> np.ndarray:
    """A frame whose content changes with `index`: a bright square moving over a colour gradient."""
    frame = np.zeros((height, width, 3), np.uint8)
    frame[..., 0] = np.linspace(0, 255, width, dtype=np.uint8)[None, :]
    frame[..., 2] = np.linspace(255, 0, height, dtype=np.uint8)[:, None]
    frame[8:24, 4 * index : 4 * index + 16] = (255, 255, 0)
    return frame


def decode(path: Path) -> tuple[av.video.stream.VideoStream, list[np.ndarray]]:
    """The video stream of an MP4 and its frames as RGB arrays, decoded with PyAV."""
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        return stream, [frame.to_ndarray(format="rgb24") for frame in container.decode(stream)]


def test_video_writer_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "clips" / "run.mp4"
    with VideoWriter(path, fps=12.0) as video:
        for index in range(10):
            video.write(gradient(index))
        assert not path.exists()  # still in its temporary file
    stream, frames = decode(path)
    assert (stream.codec_context.name, stream.codec_context.format.name) == ("h264", "yuv420p")
    assert stream.average_rate == 12 and len(frames) == 10 and frames[0].shape == (48, 64, 3)
    for index, frame in enumerate(frames):  # lossy codec (and 4:2:0 chroma): close to what was written
        assert np.abs(frame.astype(int) - gradient(index)).mean() < 6
    assert frames[3][16, 20].tolist() == pytest.approx([255, 255, 0], abs=24)  # the moving square, in RGB order
    head = path.read_bytes()[:4096]
    assert b"moov" in head and head.index(b"moov") < path.read_bytes().index(b"mdat")  # +faststart: index first
    assert sorted(p.name for p in path.parent.iterdir()) == ["run.mp4"]  # no temporary file left
    bgr_frames, fps = read_video(path)  # OpenCV (the other tests' reader) decodes it too
    assert len(bgr_frames) == 10 and fps == pytest.approx(12.0)


def test_video_writer_pads_odd_sizes_and_keeps_fractional_rates(tmp_path: Path) -> None:
    path = tmp_path / "odd.mp4"
    with VideoWriter(path, fps=100 / 3, keyframe_interval=2) as video:  # 0.03 s per frame
        for index in range(5):
            video.write(gradient(index, height=47, width=63))
    stream, frames = decode(path)
    assert (stream.width, stream.height) == (64, 48) and stream.average_rate == Fraction(100, 3)
    assert len(frames) == 5
    for index, frame in enumerate(frames):  # the added column and row repeat the last ones
        expected = np.pad(gradient(index, height=47, width=63), ((0, 1), (0, 1), (0, 0)), mode="edge")
        assert np.abs(frame.astype(int) - expected).mean() < 6
    with av.open(str(path)) as container:
        keyframes = [packet.is_keyframe for packet in container.demux(video=0) if packet.size]
    assert keyframes == [True, False, True, False, True]


def test_video_writer_rejects_bad_frames_and_empty_videos(tmp_path: Path) -> None:
    video = VideoWriter(tmp_path / "a.mp4", fps=30)
    with pytest.raises(ValueError, match=r"\(H, W, 3\) uint8 RGB"):
        video.write(np.zeros((48, 64), np.uint8))
    with pytest.raises(ValueError, match=r"\(H, W, 3\) uint8 RGB"):
        video.write(np.zeros((48, 64, 3), np.float32))
    video.write(gradient(0))
    with pytest.raises(ValueError, match="frame 1 is 32x48, the video is 64x48"):
        video.write(np.zeros((48, 32, 3), np.uint8))
    assert video.close() == tmp_path / "a.mp4"
    with pytest.raises(JoshuaError, match="no frames were written"):
        VideoWriter(tmp_path / "b.mp4", fps=30).close()
    with pytest.raises(ValueError, match="fps > 0"):
        VideoWriter(tmp_path / "c.mp4", fps=0)


def test_video_writer_keeps_what_was_recorded_when_the_run_fails(tmp_path: Path) -> None:
    path = tmp_path / "partial.mp4"
    with pytest.raises(RuntimeError, match="simulated failure"), VideoWriter(path, fps=30) as video:
        for index in range(3):
            video.write(gradient(index))
        raise RuntimeError("simulated failure")
    assert len(read_video(path)[0]) == 3


# Writes 40 frames of noise (hard to compress) to argv[1] as `joshua` would, under each file-size limit in argv[2:]
# (-1: none; a write past it fails as on a full disk; SIGXFSZ ignored); prints each attempt's exit status and stderr.
WRITE_UNDER_SIZE_LIMITS = """
import contextlib, io, json, resource, signal, sys
from pathlib import Path
import numpy as np
from joshua_core.cli import os_errors_reported
from joshua_core.interrupts import reported
from joshua_render import VideoWriter

def job() -> int:
    with VideoWriter(Path(sys.argv[1]), fps=30) as video:
        for index in range(40):
            video.write(np.random.default_rng(index).integers(0, 256, (48, 64, 3), np.uint8))
    return 0

signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
for limit in map(int, sys.argv[2:]):
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, resource.RLIM_INFINITY))
    stderr = io.StringIO()
    with contextlib.redirect_stderr(stderr):
        status = reported(lambda: os_errors_reported(job))
    resource.setrlimit(resource.RLIMIT_FSIZE, (resource.RLIM_INFINITY, resource.RLIM_INFINITY))
    print(json.dumps([status, stderr.getvalue()]), flush=True)
"""


def test_video_writer_on_a_full_disk_is_one_line_and_leaves_the_earlier_file(tmp_path: Path) -> None:
    finished = tmp_path / "finished.mp4"
    whole = subprocess.run(
        [sys.executable, "-c", WRITE_UNDER_SIZE_LIMITS, str(finished), "-1"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert whole.stdout == '[0, ""]\n' and finished.is_file(), whole.stderr[-3000:]
    path = tmp_path / "eval.mp4"
    path.write_bytes(b"the earlier video")
    # the first write (the header: FFmpeg crashed when flushed after it) fails, then the last one, in close()
    limits = [0, finished.stat().st_size - 1]
    attempts = subprocess.run(
        [sys.executable, "-c", WRITE_UNDER_SIZE_LIMITS, str(path), *map(str, limits)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert attempts.returncode == 0, attempts.stderr[-3000:]
    reported = [json.loads(line) for line in attempts.stdout.splitlines()]
    assert reported == [[2, f"joshua: error: {path}: File too large\n"]] * len(limits)
    assert path.read_bytes() == b"the earlier video" and sorted(p.name for p in tmp_path.iterdir()) == [
        "eval.mp4", "finished.mp4"
    ]  # fmt: skip


def test_open_display_records_one_frame_per_interval_without_a_display(
    engine: SceneEngine, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with open_display(engine, output_dir=tmp_path, name="sim_passive", fps=10.0, camera="side") as display:
        assert isinstance(display, RecordingDisplay)
        assert display.description == f"recording to {tmp_path / 'sim_passive.mp4'}"
        for step in range(101):  # 1 s of sim time in 10 ms steps -> frames at 0.0, 0.1, ..., 1.0
            engine.step(5)
            assert display.update(step * 0.01) is True
        video = display.close()
    assert video == tmp_path / "sim_passive.mp4"
    frames, fps = read_video(video)
    assert len(frames) == 11 and fps == pytest.approx(10.0)
    assert frames[0].shape == (120, 160, 3)
    rgb = frames[-1][..., ::-1]
    assert distinct_colours(rgb) > 200 and orange_pixels(rgb) > 50  # the arm is in the picture


def test_recording_duplicates_frames_over_time_gaps_and_restarts_when_time_goes_back(
    engine: SceneEngine, tmp_path: Path
) -> None:
    display = RecordingDisplay(engine, tmp_path / "gaps.mp4", fps=10.0)
    for time in (0.0, 0.05, 0.31):  # frames due at 0.0, then 0.1, 0.2, 0.3 all passed by 0.31
        display.update(time)
    assert display.frames == 4
    display.update(0.0)  # a loop started again: a new frame at once
    assert display.frames == 5
    assert len(read_video(display.close())[0]) == 5


def test_viewer_without_a_display_is_a_usage_error(engine: SceneEngine, tmp_path: Path, monkeypatch) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(UsageError) as error:
        open_display(engine, output_dir=tmp_path, name="x", viewer=True)
    message = str(error.value)
    assert "DISPLAY is not set" in message and "sim_offscreen" in message and "Xvfb" in message
    monkeypatch.setenv("DISPLAY", ":199")  # named, but no server there
    with pytest.raises(UsageError, match="cannot connect to display ':199'"):
        open_display(engine, output_dir=tmp_path, name="x", viewer=True)
    auto = open_display(engine, output_dir=tmp_path, name="auto")  # auto: records instead
    assert isinstance(auto, RecordingDisplay) and auto.close() is None  # nothing recorded, no file
    assert not (tmp_path / "auto.mp4").exists()


def test_unknown_camera_lists_the_cameras(engine: SceneEngine, tmp_path: Path) -> None:
    with pytest.raises(UsageError, match="no camera 'top' in the model; cameras: overview, side"):
        open_display(engine, output_dir=tmp_path, name="x", camera="top", viewer=False)


class _SignalAfterEncode:
    """A video stream whose encoder output is followed at once by SIGINT, the first time it gives packets: a
    Ctrl-C between the encoder and the muxer, where raising would drop a packet that later frames refer to."""

    def __init__(self, stream: Any) -> None:
        self.stream = stream
        self.signalled = False

    def encode(self, picture: av.VideoFrame | None) -> list[av.Packet]:
        packets = self.stream.encode(picture)
        if packets and not self.signalled:
            self.signalled = True
            signal.raise_signal(signal.SIGINT)
        return packets


def test_ctrl_c_while_a_frame_is_encoded_keeps_every_frame_decodable(tmp_path: Path) -> None:
    path = tmp_path / "stopped.mp4"
    written = 0
    with pytest.raises(KeyboardInterrupt), VideoWriter(path, fps=30) as video:
        video.write(gradient(0))
        video._stream = _SignalAfterEncode(video._stream)  # the encoder, where the signal lands
        for index in range(1, 40):
            written = index
            video.write(gradient(index))
    assert video.frames == written + 1  # the interrupted frame was written whole before the interrupt came
    _, frames = decode(path)
    assert len(frames) == written + 1
    for index, frame in enumerate(frames):
        assert np.abs(frame.astype(int) - gradient(index)).mean() < 6
