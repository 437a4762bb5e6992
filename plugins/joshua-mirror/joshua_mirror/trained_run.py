"""A trained run as `joshua checklist` reads it: the run's config.json and metrics.json, the task built on its model as
training built it, and its exported policy checked as `joshua deploy` checks it. A problem with the input is one
UsageError (exit 2); an export that does not match the run is kept as a problem for the checklist to mark."""

from __future__ import annotations

import argparse
import importlib.util
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from joshua_core.errors import UsageError
from joshua_core.json_files import read_json_object
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_core.runs import CONFIG_FILE, METRICS_FILE, read_run_config, resolve_checkpoint, saved_training
from joshua_core.tasks import Task


@dataclass
class Run:
    """What the run's files say, and the task built on its model."""

    given: Path  # the RUN argument, as the commands print it
    checkpoint: Path
    trainer: str
    training: Any  # joshua.TrainingConfig
    model_path: Path
    task: Task
    model: mujoco.MjModel
    record: dict[str, Any] | None  # metrics.json's last record
    policy_dir: Path
    contract: dict[str, Any] | None = None
    contract_problems: list[str] = field(default_factory=list)

    @property
    def period(self) -> float:
        return self.task.dt

    def actuated(self) -> list[tuple[str, str, tuple[float, float] | None]]:
        """(actuator, joint, joint range or None) of each actuator, in action order."""
        found: list[tuple[str, str, tuple[float, float] | None]] = []
        for index in range(self.model.nu):
            actuator = self.model.actuator(index)
            joint_id = int(self.model.actuator_trnid[index, 0])
            if self.model.actuator_trntype[index] != mujoco.mjtTrn.mjTRN_JOINT:
                found.append((actuator.name, "", None))
                continue
            joint = self.model.joint(joint_id)
            limited = bool(self.model.jnt_limited[joint_id])
            found.append(
                (actuator.name, joint.name, (float(joint.range[0]), float(joint.range[1])) if limited else None)
            )
        return found


def read_run(args: argparse.Namespace, plugins: PluginHost) -> Run:
    """The run's files read and its task built; each problem with the input one UsageError."""
    checkpoint = resolve_checkpoint(args.run)
    run_format = read_run_config(checkpoint).get("format")
    if not isinstance(run_format, str):
        raise UsageError(f'{checkpoint / CONFIG_FILE}: has no "format" entry naming the trainer\'s run format')
    checkpoint, saved, training = saved_training(checkpoint, run_format, plugins.options())
    if not training.task:
        raise UsageError(f"run {checkpoint} names no task: it has no observation a real arm could give")
    from joshua_mujoco import load_task_model

    model_path = resolve_data_path(training.model_path) if training.model_path else None
    task_config = training.task_config if training.HasField("task_config") else None
    task, model = load_task_model(training.task, model_path, plugins, task_config)
    policy_dir = args.policy or checkpoint
    if args.policy is not None and not args.policy.is_dir():
        raise UsageError(f"--policy {args.policy} is not a folder (joshua export writes one)")
    run = Run(
        given=args.run,
        checkpoint=checkpoint,
        trainer=saved["trainer"],
        training=training,
        model_path=model_path or resolve_data_path(task.spec.model_path),
        task=task,
        model=model,
        record=_last_record(checkpoint / METRICS_FILE),
        policy_dir=policy_dir,
    )
    _read_contract(run, plugins, required=args.policy is not None)
    return run


def _last_record(path: Path) -> dict[str, Any] | None:
    """The last record of metrics.json's history, or None without the file; a damaged file is a UsageError."""
    if not path.is_file():
        return None
    history = read_json_object(path, "the run's metrics").get("history")
    if not isinstance(history, list) or not all(isinstance(record, dict) for record in history):
        raise UsageError(f"{path}: 'history' is not a list of records (objects)")
    return history[-1] if history else None


def _read_contract(run: Run, plugins: PluginHost, *, required: bool) -> None:
    """The exported contract, checked as joshua deploy checks it (ONNX hash, compiled model, observation terms)
    and against the run; what does not match is a problem of the checklist."""
    if importlib.util.find_spec("joshua_export") is None:
        return
    from joshua_export import CONTRACT_FILE, contract_observer, load_policy

    if not required and not (run.policy_dir / CONTRACT_FILE).is_file():
        return
    try:
        _, run.contract = load_policy(run.policy_dir)
        contract_observer(run.contract, plugins)
    except UsageError as error:
        run.contract_problems.append(str(error))
        return
    except (KeyError, TypeError, ValueError) as error:
        run.contract_problems.append(f"{run.policy_dir / CONTRACT_FILE}: malformed contract ({error})")
        return
    contract = run.contract
    if contract.get("task") != run.training.task:
        run.contract_problems.append(
            f"the policy is of task '{contract.get('task')}', the run of '{run.training.task}'"
        )
    if Path(str(contract.get("checkpoint"))).name != run.checkpoint.name:
        run.contract_problems.append(
            f"the policy was exported from {contract.get('checkpoint')}, not {run.checkpoint}: export it again"
        )
    if not np.isclose(contract.get("control_hz", 0.0), 1.0 / run.period):
        run.contract_problems.append(f"the contract's rate {contract.get('control_hz')} Hz is not the run's")


def follower_type(run: Run) -> str | None:
    """The LeRobot follower whose joints the model has (joshua-lerobot's table), or None."""
    if importlib.util.find_spec("joshua_lerobot") is None:
        return None
    from joshua_lerobot import feature_names

    _, robot_type = feature_names([joint for _, joint, _ in run.actuated()])
    return robot_type
