"""Plain helpers of the joshua-render tests: a minimal Engine over MuJoCo, video decoding, colour counts."""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from joshua_core.interfaces import Engine
from joshua_core.resources import models_dir
from joshua_render import camera_id, create_renderer

SCENE = models_dir() / "so_arm100" / "scene.xml"


class SceneEngine(Engine):
    """The least an `Engine` needs to be shown by joshua_render: no backend plugin involved."""

    def __init__(self, path: Path, *, width: int, height: int) -> None:
        self.model = mujoco.MjModel.from_xml_path(str(path))
        self.data = mujoco.MjData(self.model)
        self._renderer = create_renderer(self.model, width, height)

    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    @property
    def time(self) -> float:
        return float(self.data.time)

    def reset(self, keyframe: str | None = None) -> None:
        if keyframe is None:
            mujoco.mj_resetData(self.model, self.data)
        else:
            mujoco.mj_resetDataKeyframe(self.model, self.data, self.model.key(keyframe).id)
        mujoco.mj_forward(self.model, self.data)

    def step(self, n: int = 1) -> None:
        mujoco.mj_step(self.model, self.data, n)

    def set_ctrl(self, values: ArrayLike) -> None:
        self.data.ctrl[:] = values

    def get_qpos(self) -> NDArray[np.float64]:
        return self.data.qpos.copy()

    def get_sensor(self, name: str) -> NDArray[np.float64]:
        return self.data.sensor(name).data.copy()

    def instability(self) -> str | None:
        return None

    def render(self, camera: str | int | None = None) -> NDArray[np.uint8]:
        self._renderer.update_scene(self.data, camera=camera_id(self.model, None) if camera is None else camera)
        return self._renderer.render()

    def close(self) -> None:
        self._renderer.close()


def headless_env(**extra: str) -> dict[str, str]:
    """This environment without a display and without the GL choice this test process made, plus `extra`."""
    dropped = ("DISPLAY", "WAYLAND_DISPLAY", "MUJOCO_GL", "PYOPENGL_PLATFORM")
    return {**{key: value for key, value in os.environ.items() if key not in dropped}, **extra}


def read_video(path: Path) -> tuple[list[NDArray[np.uint8]], float]:
    """Every frame (BGR) of a video file and its frame rate, read back with OpenCV."""
    capture = cv2.VideoCapture(str(path))
    assert capture.isOpened(), f"OpenCV cannot open {path}"
    fps = capture.get(cv2.CAP_PROP_FPS)
    frames = []
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        frames.append(frame)
    capture.release()
    return frames, fps


def distinct_colours(image: NDArray[np.uint8]) -> int:
    return len(np.unique(image.reshape(-1, image.shape[-1]), axis=0))


def orange_pixels(rgb: NDArray[np.uint8]) -> int:
    """Pixels of the SO-ARM100's printed parts (material 'printed', orange), lit or shaded."""
    r, g, b = (rgb[..., i].astype(int) for i in range(3))
    return int(np.count_nonzero((r > 150) & (r - b > 100) & (g - b > 30) & (r - g > 20)))


def green_pixels(rgb: NDArray[np.uint8]) -> int:
    """Pixels of the markers render_with_commands draws (green, partly transparent)."""
    r, g, b = (rgb[..., i].astype(int) for i in range(3))
    return int(np.count_nonzero((g > 120) & (g - r > 60) & (g - b > 40)))
