"""Loading an exported policy: its contract checked, the ONNX file verified by hash and run by onnxruntime,
and the task's observer rebuilt and checked against the contract (same robot model, same terms)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import onnxruntime
from google.protobuf import text_format
from numpy.typing import ArrayLike, NDArray
from onnxruntime.capi import onnxruntime_pybind11_state as onnxruntime_errors

from joshua_core.config_pb2 import TaskConfig
from joshua_core.errors import UsageError
from joshua_core.json_files import read_json_object
from joshua_core.limits import MAX_CONTROL_HZ, MIN_CONTROL_HZ
from joshua_core.outputs import check_name
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_export.contract import CONTRACT_FILE, CONTRACT_FORMAT, sha256
from joshua_export.observer import Observer, model_sha256

# What onnxruntime raises for a file it cannot load as a graph (its errors derive from Exception alone).
ONNXRUNTIME_LOAD_ERRORS = (
    onnxruntime_errors.Fail,
    onnxruntime_errors.InvalidArgument,
    onnxruntime_errors.InvalidGraph,
    onnxruntime_errors.InvalidProtobuf,
    onnxruntime_errors.NoSuchFile,
    onnxruntime_errors.NotImplemented,
    onnxruntime_errors.RuntimeException,
)


class OnnxPolicy:
    """An exported policy run by onnxruntime on the CPU: observations (N, obs) or (obs,) -> actions in [-1, 1]."""

    def __init__(self, path: Path) -> None:
        options = onnxruntime.SessionOptions()
        options.intra_op_num_threads = 1  # one small MLP per control step: threads only add latency
        self.session = onnxruntime.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
        (self.input,), (self.output,) = self.session.get_inputs(), self.session.get_outputs()

    def __call__(self, observations: ArrayLike) -> NDArray[np.float32]:
        batch = np.asarray(observations, np.float32)
        single = batch.ndim == 1
        (actions,) = self.session.run([self.output.name], {self.input.name: batch[None] if single else batch})
        return actions[0] if single else actions


def load_policy(folder: Path) -> tuple[OnnxPolicy, dict[str, Any]]:
    """The policy exported to `folder` and its contract (policy.json); a missing, foreign or changed file is a
    one-line UsageError."""
    path = folder / CONTRACT_FILE
    if not path.exists():
        raise UsageError(f"'{folder}' holds no exported policy: no {CONTRACT_FILE} (see `joshua export`)")
    contract = read_json_object(path, "the policy's contract")
    if contract.get("format") != CONTRACT_FORMAT:
        raise UsageError(f"{path} is not a {CONTRACT_FORMAT} contract")
    rate = contract.get("control_hz")
    if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not MIN_CONTROL_HZ <= rate <= MAX_CONTROL_HZ:
        raise UsageError(
            f"{path}: control_hz is {rate!r}; expected a number of Hz from {MIN_CONTROL_HZ:g} to {MAX_CONTROL_HZ:g}"
        )
    entry = contract.get("model")
    if not isinstance(entry, dict) or not all(isinstance(entry.get(key), str) for key in ("file", "sha256")):
        raise UsageError(f"{path}: model is {entry!r}; expected the ONNX file's name and sha256 (see `joshua export`)")
    model = folder / check_name(entry["file"], f"{path}: model.file")  # the file beside the contract, no other
    if not model.is_file() or sha256(model.read_bytes()) != entry["sha256"]:
        raise UsageError(f"{model} is missing or is not the file {path} describes (its sha256 differs)")
    try:
        return OnnxPolicy(model), contract
    except ONNXRUNTIME_LOAD_ERRORS as error:
        reason = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise UsageError(f"{model}: onnxruntime cannot load it as a policy: {reason}") from None


def contract_observer(contract: dict[str, Any], plugins: PluginHost, model_path: Path | None = None) -> Observer:
    """The task's observer for a contract (on `model_path`, else the contract's robot model), refused with one
    line when the compiled model or the observation terms differ from what the policy was exported with."""
    task_config = text_format.Parse(contract["task_config"], TaskConfig()) if contract["task_config"] else None
    path = model_path or resolve_data_path(contract["robot"]["model_path"])
    observer = Observer.load(contract["task"], path, plugins, task_config)
    if model_sha256(observer.model) != contract["robot"]["sha256"]:
        raise UsageError(
            f"robot model {path} is not the one the policy was trained on (its compiled sha256 differs from the "
            "contract's); deploy on the training model, with the same MuJoCo version"
        )
    built = [[name, term, start, stop] for name, term, start, stop in observer.term_slices()]
    expected = [[term["name"], term["term"], term["start"], term["stop"]] for term in contract["observation"]["terms"]]
    if built != expected:
        raise UsageError(f"task '{contract['task']}' now builds the observation {built}; the policy expects {expected}")
    return observer
