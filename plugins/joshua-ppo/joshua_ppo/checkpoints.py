"""PPO checkpoints, laid out as the product description shows:

    <checkpoint_dir>/<run>_step_<N>/
        params.msgpack       {"params": network parameters, "normalizer": {count, mean, variance}} (Flax msgpack)
        train_state.msgpack  optimiser state, random key and counters: what resuming needs besides params
        config.json          trainer, task, model, seed, every hyper-parameter, versions
        metrics.json         returns, lengths, losses, entropy and steps/s per iteration, wall and compile time
    <checkpoint_dir>/<run>/  the run's own folder: config.json, metrics.json, training_curves.png,
                             tensorboard/, videos/

Each checkpoint folder is written to a temporary folder and renamed into place, so a crash leaves
either the whole checkpoint or none. msgpack holds only arrays and numbers: loading one never runs code.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import jax
from flax import serialization

from joshua_core.atomic import atomic_directory, atomic_write_json
from joshua_core.errors import JoshuaError, UsageError
from joshua_core.evaluation import read_run_config
from joshua_ppo.config_settings import PpoSettings
from joshua_ppo.envs import JaxEnv
from joshua_ppo.normalizer import RunningStatistics
from joshua_ppo.settings import NetworkSettings, OptimizationSettings
from joshua_ppo.state import Progress, TrainingState, init_state

PARAMS_FILE = "params.msgpack"
TRAIN_STATE_FILE = "train_state.msgpack"
CONFIG_FILE = "config.json"
METRICS_FILE = "metrics.json"
CHECKPOINT_FILES = (PARAMS_FILE, TRAIN_STATE_FILE, CONFIG_FILE, METRICS_FILE)
_STEP_SUFFIX = re.compile(r"_step_(\d+)$")


class CorruptCheckpointError(JoshuaError):
    """A checkpoint file is missing, truncated or does not fit the network it is loaded into."""


def checkpoint_dir(root: Path, run: str, step: int) -> Path:
    return root / f"{run}_step_{step}"


def checkpoint_step(folder: Path) -> int:
    match = _STEP_SUFFIX.search(folder.name)
    if match is None:
        raise UsageError(f"'{folder}' is not a checkpoint folder (<run>_step_<N>)")
    return int(match.group(1))


def run_checkpoints(root: Path, run: str) -> list[Path]:
    """The run's complete checkpoint folders, oldest first."""
    name = re.compile(rf"^{re.escape(run)}_step_\d+$")
    folders = [path for path in root.iterdir() if name.match(path.name)] if root.is_dir() else []
    complete = [path for path in folders if all((path / file).is_file() for file in CHECKPOINT_FILES)]
    return sorted(complete, key=checkpoint_step)


def resolve_checkpoint(path: Path) -> Path:
    """A checkpoint folder itself, or the newest checkpoint of a run folder `<root>/<run>`."""
    if _STEP_SUFFIX.search(path.name) and (path / PARAMS_FILE).exists():
        return path
    read_run_config(path)  # a clear error when `path` is neither
    checkpoints = run_checkpoints(path.parent, path.name)
    if not checkpoints:
        raise UsageError(f"run '{path}' has no checkpoint yet (looked for {path.parent}/{path.name}_step_<N>/)")
    return checkpoints[-1]


def write_checkpoint(folder: Path, payloads: dict[str, Any], documents: dict[str, Any]) -> Path:
    """Write the msgpack payloads and JSON documents into `folder`, atomically."""
    with atomic_directory(folder) as temporary:
        for name, tree in payloads.items():
            (temporary / name).write_bytes(serialization.to_bytes(tree))
        for name, document in documents.items():
            atomic_write_json(temporary / name, document)
    return folder


def read_payload(folder: Path, name: str, target: Any) -> Any:
    """Restore `folder/name` into the structure of `target` (arrays of the same shapes)."""
    path = folder / name
    if not path.is_file():
        raise CorruptCheckpointError(f"checkpoint {folder} has no {name}; it is incomplete")
    try:
        return serialization.from_bytes(target, path.read_bytes())
    except Exception as error:  # msgpack and flax raise many types for truncated or mismatched files
        raise CorruptCheckpointError(
            f"cannot load {path}: {type(error).__name__}: {error} (the file is damaged, or was written for "
            "another task or network size)"
        ) from None


def read_json(path: Path) -> dict[str, Any]:
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise CorruptCheckpointError(f"cannot read {path}: {error}") from None
    if not isinstance(document, dict):
        raise CorruptCheckpointError(f"{path} does not hold a JSON object")
    return document


def load_params(checkpoint: Path, env: JaxEnv, network: NetworkSettings) -> tuple[Any, RunningStatistics]:
    """A checkpoint's network parameters and observation normaliser, checked against the network's shapes."""
    template = init_state(env, seed=0, network=network, optimization=OptimizationSettings())
    saved = read_payload(
        checkpoint, PARAMS_FILE, {"params": template.params, "normalizer": template.normalizer._asdict()}
    )
    return saved["params"], RunningStatistics(**saved["normalizer"])


def load_state(checkpoint: Path, env: JaxEnv, settings: PpoSettings) -> tuple[TrainingState, Progress]:
    """The full training state of a checkpoint (environments freshly reset), for resuming."""
    template = init_state(env, seed=settings.seed, network=settings.network, optimization=settings.optimization)
    params, normalizer = load_params(checkpoint, env, settings.network)
    target = {"opt_state": template.opt_state, "key": template.key, "iteration": 0, "env_steps": 0}
    saved = read_payload(checkpoint, TRAIN_STATE_FILE, target)
    state = TrainingState(
        params, saved["opt_state"], normalizer, env.reset(jax.random.fold_in(saved["key"], 1)), saved["key"]
    )
    state = jax.device_put(state, jax.tree.map(lambda leaf: leaf.sharding, template))
    return state, Progress(int(saved["iteration"]), int(saved["env_steps"]))
