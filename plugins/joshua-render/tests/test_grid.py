"""GridVideoWriter: episodes tiled in one MP4 read back with OpenCV, finished tiles holding, labels drawn."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from render_testing import read_video

from joshua_render import GridVideoWriter, episode_label, grid_shape

HEIGHT, WIDTH = 48, 96


def solid(colour: tuple[int, int, int]) -> np.ndarray:
    """A frame of one colour."""
    return np.broadcast_to(np.array(colour, np.uint8), (HEIGHT, WIDTH, 3)).copy()


def test_grid_shape_is_as_square_as_can_be() -> None:
    assert [grid_shape(n) for n in (1, 2, 3, 4, 5, 9, 10)] == [(1, 1), (1, 2), (2, 2), (2, 2), (2, 3), (3, 3), (3, 4)]
    with pytest.raises(ValueError):
        grid_shape(0)


def test_labels_name_the_episode_its_return_and_outcome() -> None:
    assert episode_label(0, 12.345) == "episode 1  return 12.35"
    assert episode_label(2, -3.0, True) == "episode 3  return -3  success"
    assert episode_label(3, 0.5, False) == "episode 4  return 0.5  failure"


def test_three_episodes_tile_a_two_by_two_video(tmp_path: Path) -> None:
    path = tmp_path / "grid.mp4"
    colours = [(200, 40, 40), (40, 200, 40), (40, 40, 200)]
    labels = ["WWWWWW", "b", "c"]  # wide letters: enough pixels to find after compression
    with GridVideoWriter(path, fps=10.0, tiles=3) as video:
        video.write([solid(colour) for colour in colours], labels)
        for _ in range(3):  # the first episode has ended: its tile holds its last frame
            video.write([None, solid((220, 220, 40)), solid(colours[2])], labels)
        assert video.frames == 4 and not path.exists()
    frames, fps = read_video(path)
    assert len(frames) == 4 and fps == pytest.approx(10.0)
    last = frames[-1][..., ::-1].astype(int)  # RGB
    assert last.shape == (2 * HEIGHT, 2 * WIDTH, 3)
    below_label = slice(HEIGHT // 2, HEIGHT), slice(0, WIDTH)  # the label sits at the top left
    for (row, column), colour in zip([(0, 0), (0, 1), (1, 0)], [colours[0], (220, 220, 40), colours[2]], strict=True):
        tile = last[row * HEIGHT : (row + 1) * HEIGHT, column * WIDTH : (column + 1) * WIDTH]
        assert np.abs(tile[below_label] - colour).mean() < 15, (row, column, tile[below_label].mean(axis=(0, 1)))
    assert last[HEIGHT + 4 :, WIDTH + 4 :].max() < 30  # the fourth tile, with no episode, is black
    label = last[4:26, 4:WIDTH]  # white text on a darkened box over the red tile
    assert (label.min(axis=-1) > 170).sum() > 10 and (label.max(axis=-1) < 80).sum() > 10


def test_a_frame_per_tile_and_label_is_required(tmp_path: Path) -> None:
    with GridVideoWriter(tmp_path / "grid.mp4", fps=10.0, tiles=2) as video:
        with pytest.raises(ValueError, match="expected 2 frames and labels, got 1 and 2"):
            video.write([solid((0, 0, 0))], ["a", "b"])
        with pytest.raises(ValueError, match="tile 1 has no frame yet"):
            video.write([solid((0, 0, 0)), None], ["a", "b"])
        video.write([solid((9, 9, 9)), solid((9, 9, 9))], ["a", "b"])
    assert len(read_video(tmp_path / "grid.mp4")[0]) == 1
