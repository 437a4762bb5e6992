"""`train_mjx(model_path=..., config={...})`: the Python entry point to GPU training (docs/training-mjx.md)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from google.protobuf import json_format

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.defaults import training_output_dir, training_plugins
from joshua_core.errors import ConfigError
from joshua_core.kinds import Kind
from joshua_core.options import parse_dict
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_core.run_context import RunContext
from joshua_core.tasks import load_task_spec
from joshua_ppo.trainer import PpoTrainer


def train_mjx(
    model_path: str | Path,
    config: Mapping[str, Any] | None = None,
    *,
    task: str | None = None,
    checkpoint_dir: str | Path | None = None,
    plugins: PluginHost | None = None,
) -> Path:
    """Train PPO on MJX and return the last checkpoint folder.

    `config` holds TrainingConfig fields by name (num_envs, num_steps, num_epochs, minibatch_size,
    learning_rate, gamma, gae_lambda, clip_epsilon, total_timesteps, seed, task, checkpoint_dir, and
    `ppo`: {...} for PpoOptions); unknown names are a ConfigError. The task defaults to the registered
    task whose model is `model_path` (or the variant of it the backend simulates, e.g. ant/ant_mjx.xml on mjx),
    e.g. ant/ant.xml -> ant_locomotion.
    Runs go to `checkpoint_dir`, else the config's, else the folder the `joshua` command uses
    (`joshua_core.config.training_output_dir`).
    """
    host = plugins or PluginHost.discover()
    training = TrainingConfig()
    try:
        parse_dict(dict(config or {}), training, host.options())
    except json_format.ParseError as error:
        raise ConfigError(f"train_mjx config: {error}") from None
    training.model_path = str(resolve_data_path(model_path))
    training.task = task or training.task or _task_for_model(Path(training.model_path), training, host)
    training.checkpoint_dir = str(checkpoint_dir or training_output_dir(training))
    return PpoTrainer().train(training, RunContext(host, Path(training.checkpoint_dir)))


def _task_for_model(model_path: Path, training: TrainingConfig, plugins: PluginHost) -> str:
    """The registered task whose model file is `model_path`, or has `model_path` as the variant that the training's
    backend simulates (asked of the backend, so the trainer knows no backend's file names)."""
    backend = plugins.backend(training_plugins(training)[1])
    matches = []
    for name in plugins.names(Kind.TASK):
        spec_path = resolve_data_path(load_task_spec(name, plugins).model_path)
        same = spec_path.parent == model_path.parent and spec_path.stem == model_path.stem
        if same or backend.model_variant(spec_path) == model_path:
            matches.append(name)
    if len(matches) != 1:
        found = f"tasks {', '.join(matches)} use it" if matches else "no registered task uses it"
        raise ConfigError(f"train_mjx: {found}; name one with task=... (see `joshua plugins`)")
    return matches[0]
