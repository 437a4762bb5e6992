"""Camera videos as LeRobot reads them: joshua_render's H.264 (yuv420p) MP4, of the exact size the dataset records.

lerobot 0.4.4 writes AV1 by default but decodes any codec its decoder's FFmpeg knows (torchcodec, or PyAV
through torchvision); H.264 is the one every FFmpeg build and every browser (LeRobot's dataset viewer) plays.
"""

from __future__ import annotations

from pathlib import Path

from joshua_core.errors import UsageError
from joshua_render import VideoWriter

CODEC_NAME, PIXEL_FORMAT = VideoWriter.CODEC_NAME, VideoWriter.PIXEL_FORMAT  # info.json's video.codec, video.pix_fmt
KEYFRAME_INTERVAL = 2  # as lerobot's encoder: any frame decodes after at most one other


class Mp4Writer(VideoWriter):
    """A VideoWriter for one camera of a dataset: `width` x `height` must be even, since info.json records the
    frame size and yuv420p cannot store an odd one unpadded."""

    def __init__(self, path: Path, fps: int, width: int, height: int) -> None:
        check_frame_size(width, height)
        super().__init__(path, fps, keyframe_interval=KEYFRAME_INTERVAL)


def check_frame_size(width: int, height: int) -> None:
    """A UsageError unless `width` x `height` can be a dataset's video: yuv420p stores only even sizes unpadded."""
    if width % 2 or height % 2:
        raise UsageError(f"camera videos need an even width and height (yuv420p), got {width}x{height}")
