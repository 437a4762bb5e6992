"""An MP4 of several episodes side by side: `joshua eval --grid N` shows N episodes at once, not a lucky one.

Tile i shows episode i+1 in a grid of ceil(sqrt(N)) columns, labelled with its number and return (and at its
end whether it succeeded); a tile whose episode ended holds its last frame until the longest one ends.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType

import cv2
import numpy as np
from numpy.typing import NDArray

from joshua_render.video import VideoWriter

LABEL_SCALE = 0.6  # cv2.FONT_HERSHEY_SIMPLEX height factor: about 13 px per line on a 640x480 tile
LABEL_ORIGIN = (8, 22)  # px from the tile's top left: the text's baseline start
LABEL_PADDING = 4  # px of dark box around the text


def grid_shape(tiles: int) -> tuple[int, int]:
    """(rows, columns) of a grid of `tiles` tiles: as square as can be, wider than tall (3 -> 2x2, 6 -> 2x3)."""
    if tiles < 1:
        raise ValueError(f"a grid needs at least one tile, got {tiles}")
    columns = math.ceil(math.sqrt(tiles))
    return math.ceil(tiles / columns), columns


def episode_label(index: int, episode_return: float, success: bool | None = None) -> str:
    """A tile's label: `episode 3  return 12.5`, and `success` or `failure` once the outcome is known."""
    outcome = "" if success is None else ("  success" if success else "  failure")
    return f"episode {index + 1}  return {episode_return:.4g}{outcome}"


def draw_label(frame: NDArray[np.uint8], text: str) -> NDArray[np.uint8]:
    """A copy of an RGB frame with `text` at its top left, white on a dark box (legible on any scene)."""
    labelled = frame.copy()
    (width, height), baseline = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, LABEL_SCALE, 1)
    (x, y), pad = LABEL_ORIGIN, LABEL_PADDING
    labelled[max(0, y - height - pad) : y + baseline + pad, max(0, x - pad) : x + width + pad] //= 4  # darkened
    cv2.putText(labelled, text, LABEL_ORIGIN, cv2.FONT_HERSHEY_SIMPLEX, LABEL_SCALE, (255, 255, 255), 1, cv2.LINE_AA)
    return labelled


class GridVideoWriter:
    """Writes frames of `tiles` episodes, tiled and labelled, to an MP4 at `path` (atomically, by VideoWriter).

    Every `write` gives one frame per tile, all of one size, or None for a tile whose episode has ended (its
    last frame is shown again). A context manager, like VideoWriter.
    """

    def __init__(self, path: Path, fps: float, tiles: int) -> None:
        self.rows, self.columns = grid_shape(tiles)
        self.tiles = tiles
        self._video = VideoWriter(path, fps)
        self._last: list[NDArray[np.uint8] | None] = [None] * tiles

    @property
    def frames(self) -> int:
        """Frames written so far."""
        return self._video.frames

    def write(self, frames: Sequence[NDArray[np.uint8] | None], labels: Sequence[str]) -> None:
        """Append one grid frame: tile i shows `frames[i]` (None: its previous frame) labelled `labels[i]`."""
        if len(frames) != self.tiles or len(labels) != self.tiles:
            raise ValueError(f"expected {self.tiles} frames and labels, got {len(frames)} and {len(labels)}")
        for index, frame in enumerate(frames):
            if frame is not None:
                self._last[index] = frame
        shown = [frame for frame in self._last if frame is not None]
        if not shown:
            raise ValueError("the first grid frame needs a frame for every tile")
        height, width = shown[0].shape[:2]
        grid = np.zeros((self.rows * height, self.columns * width, 3), np.uint8)
        for index, (frame, label) in enumerate(zip(self._last, labels, strict=True)):
            if frame is None:
                raise ValueError(f"tile {index} has no frame yet")
            row, column = divmod(index, self.columns)
            grid[row * height : (row + 1) * height, column * width : (column + 1) * width] = draw_label(frame, label)
        self._video.write(grid)

    def close(self) -> Path:
        """Finish the MP4 and move it to its path (returned)."""
        return self._video.close()

    def __enter__(self) -> GridVideoWriter:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, traceback: TracebackType | None
    ) -> None:
        self._video.__exit__(exc_type, exc, traceback)
