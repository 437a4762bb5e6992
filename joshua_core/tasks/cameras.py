"""Cameras a task renders as observations: the scene's cameras by name, each with an image size, a kind and how
often it renders. The home of their defaults and checks; backends that render (joshua-mjx on MuJoCo Warp) read
the resolved `Camera`s of a built task. See docs/tasks.md#cameras.

An image is (N, height, width, channels) per camera: "rgb" uint8 (3 channels), "depth" float32 metres along the
camera's axis (1 channel, 0 where nothing is hit), "segmentation" int32 geom ids (1 channel, -1 for background).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from joshua_core.errors import ConfigError
from joshua_core.tasks.handles import _lookup

CAMERA_KINDS = ("rgb", "depth", "segmentation")
DEFAULT_SIZE = 64  # pixels on each side, where a camera gives no width or height
_CHANNELS = {"rgb": 3, "depth": 1, "segmentation": 1}
_DTYPES: dict[str, np.dtype] = {
    "rgb": np.dtype(np.uint8),
    "depth": np.dtype(np.float32),
    "segmentation": np.dtype(np.int32),
}


@dataclass(frozen=True)
class CameraSpec:
    """One camera of a task: `camera` names the scene's camera; 0 or "" for the others takes the default (a
    DEFAULT_SIZE square "rgb" image rendered on every step). `every` k renders it on every k-th environment step
    and holds the last frame in between."""

    camera: str
    width: int = 0
    height: int = 0
    kind: str = ""
    every: int = 0


@dataclass(frozen=True)
class Camera:
    """A checked camera of a built task, with its id in the model."""

    name: str
    id: int
    width: int
    height: int
    kind: str
    every: int

    @property
    def shape(self) -> tuple[int, int, int]:
        """(height, width, channels) of one environment's image."""
        return self.height, self.width, _CHANNELS[self.kind]

    @property
    def dtype(self) -> np.dtype:
        """The image's element type."""
        return _DTYPES[self.kind]

    @property
    def bytes_per_env(self) -> int:
        """Bytes of one environment's image."""
        return math.prod(self.shape) * self.dtype.itemsize


def camera_spec(config: Any) -> CameraSpec:
    """The CameraSpec of a `joshua.CameraConfig`."""
    kind = type(config).Kind.Name(config.kind).lower() if config.kind else ""
    return CameraSpec(config.camera, config.width, config.height, kind, config.every_steps)


def resolve_cameras(task: str, specs: tuple[CameraSpec, ...], model: Any) -> tuple[Camera, ...]:
    """The task's cameras checked against the model (mujoco.MjModel): a ConfigError names the task and the camera
    for an unknown camera (listing the model's), a size below 1, an unknown kind or a camera named twice."""
    cameras = []
    for spec in specs:
        where = f"task '{task}': camera '{spec.camera}'"
        try:
            index = _lookup(model, "camera", spec.camera)
        except ValueError as error:
            raise ConfigError(f"{where}: {error}") from None
        kind = spec.kind or CAMERA_KINDS[0]
        if kind not in CAMERA_KINDS:
            raise ConfigError(f"{where}: kind must be one of {', '.join(CAMERA_KINDS)}, got '{kind}'")
        width, height = spec.width or DEFAULT_SIZE, spec.height or DEFAULT_SIZE
        if width < 1 or height < 1:
            raise ConfigError(f"{where}: width and height must be at least 1 pixel, got {width}x{height}")
        if spec.every < 0:
            raise ConfigError(f"{where}: every_steps must be at least 1 (0: every step), got {spec.every}")
        cameras.append(Camera(spec.camera, index, width, height, kind, spec.every or 1))
    names = [camera.name for camera in cameras]
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise ConfigError(f"task '{task}': cameras {', '.join(map(repr, twice))} are named more than once")
    return tuple(cameras)
