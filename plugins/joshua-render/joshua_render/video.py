"""MP4 and PNG output written atomically: a crash mid-run leaves no half-written file under the final name."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from types import TracebackType

import cv2
import numpy as np
from numpy.typing import NDArray

from joshua_core.atomic import atomic_write_bytes, remove_stale_temporaries, temporary_prefix
from joshua_core.errors import JoshuaError

# MPEG-4 Part 2: the codec the opencv-python-headless wheels can always write (their FFmpeg has no H.264 encoder).
FOURCC = "mp4v"
TEMPORARY_SUFFIX = ".tmp.mp4"  # `.offscreen.mp4.<pid>.<random>.tmp.mp4` while being written


class VideoWriter:
    """Writes RGB frames to an MP4 file: into a temporary file beside `path`, renamed to `path` by `close()`.

    The frame size is fixed by the first frame. A context manager; leaving the block calls `close()`
    (after an exception, a video with at least one frame is still finished, so nothing recorded is lost).
    """

    def __init__(self, path: Path, fps: float) -> None:
        if not fps > 0:
            raise ValueError(f"VideoWriter needs fps > 0, got {fps}")
        self.path = Path(path)
        self.fps = float(fps)
        self.frames = 0
        self._size: tuple[int, int] | None = None  # (width, height)
        self._writer: cv2.VideoWriter | None = None
        self._temporary: Path | None = None

    def write(self, frame: NDArray[np.uint8]) -> None:
        """Append one (H, W, 3) RGB uint8 frame of the size of the first one."""
        if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
            raise ValueError(f"VideoWriter expects (H, W, 3) uint8 RGB frames, got {frame.shape} {frame.dtype}")
        size = (frame.shape[1], frame.shape[0])
        if self._writer is None:
            self._open(size)
        elif size != self._size:
            assert self._size is not None
            raise ValueError(
                f"frame {self.frames} is {size[0]}x{size[1]}, the video is {self._size[0]}x{self._size[1]}"
            )
        assert self._writer is not None
        self._writer.write(cv2.cvtColor(frame, cv2.COLOR_RGB2BGR))
        self.frames += 1

    def _open(self, size: tuple[int, int]) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        remove_stale_temporaries(self.path, TEMPORARY_SUFFIX)  # left by a writer that was killed (SIGKILL)
        prefix = temporary_prefix(self.path)
        descriptor, name = tempfile.mkstemp(dir=self.path.parent, prefix=prefix, suffix=TEMPORARY_SUFFIX)
        os.close(descriptor)
        os.chmod(name, 0o644)  # mkstemp makes it private; a finished video is an ordinary output file
        self._temporary = Path(name)
        writer = cv2.VideoWriter(str(self._temporary), cv2.VideoWriter.fourcc(*FOURCC), self.fps, size)
        if not writer.isOpened():
            self._temporary.unlink(missing_ok=True)
            raise JoshuaError(f"cannot write video {self.path}: OpenCV could not open an MP4 ({FOURCC}) writer")
        self._writer, self._size = writer, size

    def close(self) -> Path:
        """Finish the file and move it to `path`; returns `path`. With no frames written it raises JoshuaError."""
        if self._writer is None:
            if self.path.is_file() and self.frames:
                return self.path  # already closed
            raise JoshuaError(f"no frames were written, so there is no video {self.path}")
        self._writer.release()
        self._writer = None
        assert self._temporary is not None
        os.replace(self._temporary, self.path)
        return self.path

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, traceback: TracebackType | None
    ) -> None:
        if exc_type is None or self._writer is not None:
            self.close()


def write_png(path: Path, image: NDArray[np.uint8] | NDArray[np.uint16]) -> None:
    """Write an RGB (H, W, 3) uint8 or a single-channel uint8/uint16 image as PNG, atomically."""
    pixels = cv2.cvtColor(image, cv2.COLOR_RGB2BGR) if image.ndim == 3 else image
    ok, encoded = cv2.imencode(".png", pixels)
    if not ok:
        raise JoshuaError(f"cannot encode {path} as PNG")
    atomic_write_bytes(path, encoded.tobytes())
