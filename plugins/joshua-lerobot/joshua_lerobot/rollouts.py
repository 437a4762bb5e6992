"""Where demonstrations come from: an `EpisodeProducer` rolls a controller out in many randomized environments at
once and hands over each finished attempt as a `Rollout` (joint positions, commanded joint targets and camera
frames, sampled at the dataset's rate, and whether the task counts it a success). `joshua demos` keeps the
successful ones and writes them as a LeRobot dataset, whatever simulates and renders them: the CPU producer
(`ScriptedMuJoCoProducer`: mujoco.batch, one `mujoco.Renderer`) or one on a GPU.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from joshua_core.errors import UsageError

# A control rate this close to a whole multiple of the dataset's fps is that multiple (dt is a float product).
RATE_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Rollout:
    """One finished attempt, sampled every `stride` control steps from its first: per row the joint positions
    before the step (`states`) and the joint targets the controller commanded at it (`actions`), both
    (rows, joints) in the model's units, and per camera one (H, W, 3) uint8 RGB frame per row, rendered before
    the step. `success`: the task's success metric at the attempt's last step (False when the environment
    terminated or was truncated before the controller finished)."""

    states: NDArray[np.float64]
    actions: NDArray[np.float64]
    frames: Mapping[str, Sequence[NDArray[np.uint8]]]
    success: bool

    @property
    def length(self) -> int:
        return len(self.states)


class EpisodeProducer(ABC):
    """A source of rollouts of one task in randomized environments, `num_envs` at a time.

    `joint_names` name the columns of every rollout's states and actions (model joints, e.g. the SO-ARM100's
    joint_1 .. joint_6), `joint_ranges` give the model's range of each (the LeRobot units map onto them),
    `cameras` the model cameras every rollout has frames of, and `task_text` says what the episodes do (the
    dataset's task unless the user gives one).
    """

    joint_names: tuple[str, ...]
    joint_ranges: dict[str, tuple[float, float]]
    cameras: tuple[str, ...]
    num_envs: int
    task_text: str

    @abstractmethod
    def rollouts(self) -> Iterator[Rollout]:
        """Finished attempts, successful or not, without end: each batch of `num_envs` environments is reset
        (fresh randomization), rolled out and yielded in environment order. Frames of at most one batch are
        held at a time."""

    @abstractmethod
    def close(self) -> None:
        """Release the simulations and renderers."""


def frame_stride(dt: float, fps: int) -> int:
    """Control steps per dataset frame: the control rate (1 / `dt`) must be a whole multiple of `fps`, so that
    every frame is a simulated step (no resampled images); otherwise a UsageError naming the rates that are."""
    rate = 1.0 / dt
    stride = round(rate / fps)
    if stride < 1 or not math.isclose(stride * fps, rate, rel_tol=RATE_TOLERANCE):
        whole = round(rate)
        usable = [str(f) for f in range(1, whole + 1) if math.isclose(whole / f, round(whole / f))]
        hint = f"; at {whole} Hz: {', '.join(usable)}" if math.isclose(rate, whole, rel_tol=RATE_TOLERANCE) else ""
        raise UsageError(
            f"--fps {fps} does not divide the task's control rate of {rate:g} steps per second: a dataset frame is "
            f"every n-th control step{hint}"
        )
    return stride
