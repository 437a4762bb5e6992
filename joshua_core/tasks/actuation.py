"""Where a task's episodes start and how its actions become controls, read off the compiled model once."""

from __future__ import annotations

from typing import Any

import numpy as np

from joshua_core.errors import ConfigError
from joshua_core.tasks.spec import ACTION_MODES, TaskSpec


def keyframe_id(spec: TaskSpec, model: Any) -> int:
    """The index of the keyframe episodes start from; -1 for the model's defaults."""
    if not spec.keyframe:
        return -1
    names = [model.key(i).name for i in range(model.nkey)]
    if spec.keyframe not in names:
        raise ConfigError(
            f"task '{spec.name}' starts from keyframe '{spec.keyframe}', which the model does not have; "
            f"its keyframes: {', '.join(names) or 'none'}"
        )
    return names.index(spec.keyframe)


def initial_state(model: Any, keyframe_id: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """qpos, qvel and ctrl of the keyframe, or of the model's defaults when there is none."""
    if keyframe_id < 0:
        return np.array(model.qpos0, dtype=np.float64), np.zeros(model.nv), np.zeros(model.nu)
    return (
        np.array(model.key_qpos[keyframe_id], dtype=np.float64),
        np.array(model.key_qvel[keyframe_id], dtype=np.float64),
        np.array(model.key_ctrl[keyframe_id], dtype=np.float64),
    )


def action_mapping(spec: TaskSpec, model: Any, initial_ctrl: np.ndarray) -> tuple[np.ndarray, ...]:
    """(ctrl_low, ctrl_high, offset, scale) with ctrl = clip(offset + scale * action, low, high)."""
    limited = np.asarray(model.actuator_ctrllimited, dtype=bool)
    ranges = np.asarray(model.actuator_ctrlrange, dtype=np.float64).reshape(-1, 2)
    low = np.where(limited, ranges[:, 0], -np.inf)
    high = np.where(limited, ranges[:, 1], np.inf)
    if spec.action.mode == "ctrl_range":
        offset = np.where(limited, (ranges[:, 0] + ranges[:, 1]) / 2, 0.0)
        scale = np.where(limited, (ranges[:, 1] - ranges[:, 0]) / 2, 1.0) * spec.action.scale
    elif spec.action.mode in ("offset", "delta"):  # delta: the offset is where each episode starts
        offset, scale = initial_ctrl.copy(), np.full(model.nu, float(spec.action.scale))
    else:
        modes = ", ".join(ACTION_MODES)
        raise ConfigError(f"task '{spec.name}': unknown action mode '{spec.action.mode}' (use {modes})")
    return low, high, offset, scale
