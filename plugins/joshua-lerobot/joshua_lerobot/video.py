"""Camera videos as LeRobot reads them: H.264 (yuv420p) MP4, written with PyAV, atomically.

lerobot 0.4.4 writes AV1 by default but decodes any codec its decoder's FFmpeg knows (torchcodec, or PyAV
through torchvision); H.264 is the one every FFmpeg build and every browser (LeRobot's dataset viewer) plays.
"""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from joshua_core.errors import UsageError

CODEC = "libx264"
CODEC_NAME = "h264"  # as info.json's video.codec names it
PIXEL_FORMAT = "yuv420p"
KEYFRAME_INTERVAL = 2  # as lerobot's encoder: any frame decodes after at most one other


class Mp4Writer:
    """Appends (H, W, 3) uint8 RGB frames of one size to an H.264 MP4 at `fps` frames per second."""

    def __init__(self, path: Path, fps: int, width: int, height: int) -> None:
        import av

        if width % 2 or height % 2:
            raise UsageError(f"camera videos need an even width and height (yuv420p), got {width}x{height}")
        self.path = path
        self.frames = 0
        self._container: Any = av.open(str(path), mode="w", format="mp4")
        stream = self._container.add_stream(CODEC, rate=fps)
        stream.width, stream.height, stream.pix_fmt = width, height, PIXEL_FORMAT
        stream.time_base = Fraction(1, fps)
        stream.options = {"g": str(KEYFRAME_INTERVAL), "preset": "veryfast", "crf": "20"}
        self._stream = stream

    def write(self, frame: NDArray[np.uint8]) -> None:
        import av

        picture = av.VideoFrame.from_ndarray(np.ascontiguousarray(frame), format="rgb24")
        picture.pts = self.frames
        self._container.mux(self._stream.encode(picture))
        self.frames += 1

    def close(self) -> None:
        self._container.mux(self._stream.encode(None))
        self._container.close()

    def __enter__(self) -> Mp4Writer:
        return self

    def __exit__(self, *exc: type[BaseException] | BaseException | TracebackType | None) -> None:
        self.close()
