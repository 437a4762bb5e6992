"""policy.json, the contract of an exported policy: what goes in, what comes out, at what rate, for which robot.

Everything a deployer needs besides the ONNX file, taken from the built task (`Observer`) and the trainer's
description of its policy, never re-typed: the observation terms in order with their slices, parameters and
scales; the normaliser (applied inside the graph, listed for reference); the action's mapping onto each
actuator; the control rate; the hashes of the ONNX file and of the compiled robot model.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np
from google.protobuf import text_format

from joshua_core.errors import UsageError
from joshua_core.policy import ExportedPolicy
from joshua_core.resources import MODELS, data_dirs
from joshua_core.tasks import Joints
from joshua_export.graph import INPUT_NAME, OUTPUT_NAME
from joshua_export.observer import Observer, model_sha256

CONTRACT_FORMAT = "joshua-policy/1"
CONTRACT_FILE = "policy.json"
ONNX_FILE = "policy.onnx"


def sha256(payload: bytes) -> str:
    return hashlib.sha256(payload).hexdigest()


def _json_param(value: Any) -> Any:
    """A term parameter as JSON: model handles by their names."""
    if isinstance(value, Joints):
        return list(value.names)
    if hasattr(value, "name") and not isinstance(value, str):
        return value.name
    return list(value) if isinstance(value, tuple) else value


def _list(array: Any) -> list[float]:
    return [float(value) for value in np.asarray(array, np.float64).ravel()]


def _observation(exported: ExportedPolicy, observer: Observer) -> dict[str, Any]:
    policy, task = exported.policy, observer.task
    params = {term.name: term.params for term in task.observation_terms}
    terms = [
        {
            "name": name,
            "term": term,
            "start": start,
            "stop": stop,
            "scale": float(params[name].get("scale", 1.0)),
            "params": {key: _json_param(value) for key, value in params[name].items()},
        }
        for name, term, start, stop in observer.term_slices()
    ]
    return {
        "size": task.observation_size,
        "terms": terms,
        "commands": dict(task.commands),
        "normalization": {
            "in_graph": True,  # the ONNX input is the raw observation
            "formula": "clip((observation - mean) / std, -clip, clip), in float64",
            "mean": _list(policy.obs_mean),
            "std": _list(policy.obs_std),
            "clip": float(policy.obs_clip) if np.isfinite(policy.obs_clip) else None,
        },
    }


_FORMULAS = {
    "ctrl_range": "ctrl = clip(offset + scale * action, ctrl_range); the ONNX output is already clipped to [-1, 1]",
    "offset": "ctrl = clip(offset + scale * action, ctrl_range); the ONNX output is already clipped to [-1, 1]",
    "delta": "ctrl = clip(ctrl_in_force + scale * action, ctrl_range), starting from offset (the task's start) or "
    "where the robot is; the observation's ctrl is ctrl_in_force; the ONNX output is already clipped to [-1, 1]",
}


def _action(observer: Observer) -> dict[str, Any]:
    task, model = observer.task, observer.model
    terms = []
    for index in range(task.action_size):
        joint = int(model.actuator_trnid[index, 0]) if model.actuator_trntype[index] == 0 else -1  # mjTRN_JOINT
        terms.append(
            {
                "actuator": model.actuator(index).name,
                "joint": model.joint(joint).name if joint >= 0 else None,
                "scale": float(task.ctrl_scale[index]),
                "offset": float(task.ctrl_offset[index]),
                "ctrl_range": [_finite(task.ctrl_low[index]), _finite(task.ctrl_high[index])],
            }
        )
    return {
        "size": task.action_size,
        "clip": [-1.0, 1.0],
        "mode": task.spec.action.mode,
        "formula": _FORMULAS[task.spec.action.mode],
        "terms": terms,
    }


def _finite(value: float) -> float | None:
    return float(value) if np.isfinite(value) else None


def portable_model_path(path: str) -> str:
    """A model inside a shipped models folder as a path relative to it (trainers record absolute paths), so the
    contract finds its model in any checkout; any other path as it is."""
    candidate = Path(path)
    if candidate.is_absolute():
        for shipped in data_dirs(MODELS):
            if candidate.is_relative_to(shipped):
                return str(candidate.relative_to(shipped))
    return path


def make_contract(exported: ExportedPolicy, observer: Observer, onnx_bytes: bytes) -> dict[str, Any]:
    """The contract of `exported` (checked against the task `observer` built), whose graph is `onnx_bytes`."""
    policy, task = exported.policy, observer.task
    if (policy.observation_size, policy.action_size) != (task.observation_size, task.action_size):
        raise UsageError(
            f"the policy of {exported.checkpoint} takes {policy.observation_size} observations and gives "
            f"{policy.action_size} actions, but task '{task.name}' has {task.observation_size} and {task.action_size}"
        )
    training = exported.training
    return {
        "format": CONTRACT_FORMAT,
        "task": task.name,
        "task_config": text_format.MessageToString(training.task_config) if training.HasField("task_config") else "",
        "trainer": exported.trainer,
        "checkpoint": str(exported.checkpoint),
        "model": {"file": ONNX_FILE, "sha256": sha256(onnx_bytes)},
        "robot": {
            "model_path": portable_model_path(training.model_path or task.spec.model_path),
            "sha256": model_sha256(observer.model),
            "timestep": float(observer.model.opt.timestep),
            "frame_skip": task.frame_skip,
        },
        "control_hz": 1.0 / task.dt,
        "onnx": {
            "inputs": [{"name": INPUT_NAME, "shape": ["batch", policy.observation_size], "dtype": "float32"}],
            "outputs": [{"name": OUTPUT_NAME, "shape": ["batch", policy.action_size], "dtype": "float32"}],
        },
        "policy": {
            "output": "the deterministic (mean) action as the trainer's evaluate sends it, after clip to [-1, 1]"
        },
        "observation": _observation(exported, observer),
        "action": _action(observer),
    }
