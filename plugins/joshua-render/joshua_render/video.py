"""MP4 and PNG output written atomically: a crash mid-run leaves no half-written file under the final name.

Videos are H.264 (yuv420p) MP4 with the index at the front (`+faststart`), the one MP4 video format every
browser plays while it downloads; PyAV's wheels bundle an FFmpeg with the libx264 encoder.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from fractions import Fraction
from pathlib import Path
from types import TracebackType
from typing import Any, ClassVar, Final

import av
import cv2
import numpy as np
from numpy.typing import NDArray

from joshua_core.atomic import atomic_write_bytes, remove_stale_temporaries, temporary_prefix
from joshua_core.errors import JoshuaError
from joshua_core.interrupts import signals_deferred

ENCODER: Final = "libx264"
ENCODER_OPTIONS = {"preset": "veryfast", "crf": "20"}  # visually near-lossless at a few hundred kB per minute
FPS_DENOMINATOR_LIMIT = 1001  # a float rate becomes a fraction, e.g. 29.97 -> 30000/1001
TEMPORARY_SUFFIX = ".tmp.mp4"  # `.offscreen.mp4.<pid>.<random>.tmp.mp4` while being written


class VideoWriter:
    """Writes RGB frames to an H.264 MP4 file: into a temporary file beside `path`, renamed to `path` by `close()`.

    The frame size is fixed by the first frame; a frame of odd width or height is padded by repeating its last
    column or row (yuv420p needs even sizes). `keyframe_interval` (frames) bounds how far back a seek decodes
    (None: the encoder's default). A context manager; leaving the block calls `close()` (after an exception, a
    video with at least one frame is still finished, so nothing recorded is lost). Where the file cannot be
    written (a full disk), the writer gives up: it removes its temporary file, leaves whatever was at `path`, and
    raises an OSError naming `path` (JoshuaError for another FFmpeg failure); every later call raises too.
    """

    CODEC_NAME: ClassVar[str] = "h264"  # the codec's name as decoders (and LeRobot's info.json) report it
    PIXEL_FORMAT: ClassVar[str] = "yuv420p"  # 4:2:0 chroma: the width and height must be even

    def __init__(self, path: Path, fps: float, keyframe_interval: int | None = None) -> None:
        if not fps > 0:
            raise ValueError(f"VideoWriter needs fps > 0, got {fps}")
        self.path = Path(path)
        self.fps = float(fps)
        self.keyframe_interval = keyframe_interval
        self.frames = 0
        self._size: tuple[int, int] | None = None  # (width, height) of the frames given
        self._container: Any = None
        self._stream: Any = None
        self._temporary: Path | None = None
        self._failed = False  # FFmpeg failed to write the file, which was given up

    def write(self, frame: NDArray[np.uint8]) -> None:
        """Append one (H, W, 3) RGB uint8 frame of the size of the first one."""
        if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
            raise ValueError(f"VideoWriter expects (H, W, 3) uint8 RGB frames, got {frame.shape} {frame.dtype}")
        if self._failed:
            raise JoshuaError(f"video {self.path} was given up after a failed write")
        size = (frame.shape[1], frame.shape[0])
        if self._container is None:
            self._open(size)
        elif size != self._size:
            assert self._size is not None
            raise ValueError(
                f"frame {self.frames} is {size[0]}x{size[1]}, the video is {self._size[0]}x{self._size[1]}"
            )
        padded = np.pad(frame, ((0, frame.shape[0] % 2), (0, frame.shape[1] % 2), (0, 0)), mode="edge")
        picture = av.VideoFrame.from_ndarray(np.ascontiguousarray(padded), format="rgb24")
        picture.pts = self.frames
        with signals_deferred():  # a Ctrl-C between encode and mux would lose a packet later frames refer to
            try:
                self._container.mux(self._stream.encode(picture))
            except av.FFmpegError as error:
                raise self._give_up(error) from None
            self.frames += 1

    def _open(self, size: tuple[int, int]) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        remove_stale_temporaries(self.path, TEMPORARY_SUFFIX)  # left by a writer that was killed (SIGKILL)
        prefix = temporary_prefix(self.path)
        descriptor, name = tempfile.mkstemp(dir=self.path.parent, prefix=prefix, suffix=TEMPORARY_SUFFIX)
        os.close(descriptor)
        os.chmod(name, 0o644)  # mkstemp makes it private; a finished video is an ordinary output file
        self._temporary = Path(name)
        rate = Fraction(self.fps).limit_denominator(FPS_DENOMINATOR_LIMIT)
        options = dict(ENCODER_OPTIONS)
        if self.keyframe_interval is not None:
            options["g"] = str(self.keyframe_interval)
        try:
            container = av.open(name, mode="w", format="mp4", options={"movflags": "+faststart"})
            stream = container.add_stream(ENCODER, rate=rate, options=options)
        except (av.FFmpegError, ValueError) as error:
            self._temporary.unlink(missing_ok=True)
            raise JoshuaError(f"cannot write video {self.path}: {error}") from error
        stream.width, stream.height = size[0] + size[0] % 2, size[1] + size[1] % 2
        stream.pix_fmt = self.PIXEL_FORMAT
        stream.time_base = 1 / rate
        self._container, self._stream, self._size = container, stream, size

    def close(self) -> Path:
        """Finish the file and move it to `path`; returns `path`. With no frames written it raises JoshuaError."""
        if self._failed:
            raise JoshuaError(f"video {self.path} was given up after a failed write")
        if self._container is None:
            if self.path.is_file() and self.frames:
                return self.path  # already closed
            raise JoshuaError(f"no frames were written, so there is no video {self.path}")
        with signals_deferred():  # often called on the way out of a Ctrl-C: a second one must not cut it short
            try:
                self._container.mux(self._stream.encode(None))  # flush the frames the encoder holds back
            except av.FFmpegError as error:
                raise self._give_up(error) from None
            container, self._container = self._container, None
            try:
                container.close()  # writes the index, moved to the front by +faststart
            except av.FFmpegError as error:
                raise self._give_up(error) from None
            assert self._temporary is not None
            os.replace(self._temporary, self.path)
        return self.path

    def _give_up(self, error: av.FFmpegError) -> Exception:
        """Abandon the video after FFmpeg failed to write it; returns the error to raise, naming `path`.

        The container is closed without another packet (muxing after a failed header write crashes FFmpeg) and
        the temporary file removed, so neither a crash nor a truncated file is left; `path` is never touched.
        """
        container, self._container, self._failed = self._container, None, True
        if container is not None:
            with contextlib.suppress(av.FFmpegError):
                container.close()
        if self._temporary is not None:
            self._temporary.unlink(missing_ok=True)
        if isinstance(error, OSError) and error.errno is not None:
            return OSError(error.errno, error.strerror, str(self.path))
        return JoshuaError(f"cannot write video {self.path}: {error}")

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, traceback: TracebackType | None
    ) -> None:
        if exc_type is None or self._container is not None:
            self.close()


def write_png(path: Path, image: NDArray[np.uint8] | NDArray[np.uint16]) -> None:
    """Write an RGB (H, W, 3) uint8 or a single-channel uint8/uint16 image as PNG, atomically."""
    pixels = cv2.cvtColor(image, cv2.COLOR_RGB2BGR) if image.ndim == 3 else image
    ok, encoded = cv2.imencode(".png", pixels)
    if not ok:
        raise JoshuaError(f"cannot encode {path} as PNG")
    atomic_write_bytes(path, encoded.tobytes())
