"""PPO checkpoints in the core's run-folder layout (`joshua_core.runs`), as docs/training-mjx.md describes:

    <checkpoint_dir>/<run>_step_<N>/
        params.msgpack       {"params": network parameters, "normalizer": {count, mean, variance}} (Flax msgpack)
        train_state.msgpack  optimiser state, random key and counters: what resuming needs besides params
        config.json          trainer, task, model, seed, every hyper-parameter, versions
        metrics.json         returns, lengths, losses, entropy and steps/s per iteration, wall and compile time
    <checkpoint_dir>/<run>/  the run's own folder: config.json, metrics.json, training_curves.png,
                             tensorboard/, videos/

Each checkpoint folder is published atomically (`RunFolder.publish`), so a crash leaves either the
whole checkpoint or none. msgpack holds only arrays and numbers: loading one never runs code.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import jax
from flax import serialization

from joshua_core.atomic import atomic_write_bytes, atomic_write_json, json_safe
from joshua_core.errors import CorruptCheckpointError
from joshua_core.json_files import read_json_object
from joshua_core.runs import RunFolder
from joshua_ppo.config_settings import PpoSettings
from joshua_ppo.envs import JaxEnv
from joshua_ppo.normalizer import RunningStatistics
from joshua_ppo.settings import NetworkSettings, OptimizationSettings
from joshua_ppo.state import Progress, TrainingState, abstract_state

RUN_FORMAT = "joshua-ppo-run/1"  # the "format" of a run's and its checkpoints' config.json
PARAMS_FILE = "params.msgpack"
TRAIN_STATE_FILE = "train_state.msgpack"
RESUME_FILES = (PARAMS_FILE, TRAIN_STATE_FILE)  # what resuming reads from a checkpoint


class NetworkMismatchError(CorruptCheckpointError):
    """The parameters saved in a checkpoint have other shapes than the network its config describes (exit 2)."""


def checkpoint_payloads(state: TrainingState, progress: Progress) -> dict[str, Any]:
    """Host copies of what a checkpoint saves of a training state: the policy (PARAMS_FILE) and what resuming
    needs besides it (TRAIN_STATE_FILE); not the environments, which `load_state` resets."""
    params = {"params": state.params, "normalizer": state.normalizer._asdict()}
    train_state = {
        "opt_state": state.opt_state,
        "key": state.key,
        "iteration": progress.iteration,
        "env_steps": progress.env_steps,
    }
    return {PARAMS_FILE: jax.device_get(params), TRAIN_STATE_FILE: jax.device_get(train_state)}


def write_payloads(folder: Path, payloads: dict[str, Any]) -> None:
    """Each payload (`checkpoint_payloads`) as the msgpack file `folder/name`, written atomically."""
    for name, tree in payloads.items():
        atomic_write_bytes(folder / name, serialization.to_bytes(tree))


def write_checkpoint(run: RunFolder, step: int, payloads: dict[str, Any], documents: dict[str, Any]) -> Path:
    """Publish checkpoint `step` of the run: the msgpack payloads and JSON documents, atomically."""
    with run.publish(step) as folder:
        write_payloads(folder, payloads)
        for name, document in documents.items():
            atomic_write_json(folder / name, json_safe(document))  # NaN/inf are not JSON: null
    return run.checkpoint_path(step)


def payload_bytes(folder: Path, name: str) -> bytes:
    """The file `folder/name` as it is (a CorruptCheckpointError when it is missing)."""
    path = folder / name
    if not path.is_file():
        raise CorruptCheckpointError(f"checkpoint {folder} has no {name}; it is incomplete")
    return path.read_bytes()


def resume_payloads(checkpoint: Path) -> dict[str, bytes]:
    """What resuming from `checkpoint` reads, as bytes: read by one process, handed to the others."""
    return {name: payload_bytes(checkpoint, name) for name in RESUME_FILES}


def _restore(path: Path, data: bytes, target: Any) -> Any:
    """`data`, the msgpack file at `path`, restored into the structure of `target`."""
    try:
        return serialization.from_bytes(target, data)
    except Exception as error:  # msgpack and flax raise many types for truncated or mismatched files
        raise CorruptCheckpointError(
            f"cannot load {path}: {type(error).__name__}: {error} (the file is damaged, or was written for "
            "another task or network size)"
        ) from None


def read_metrics(path: Path) -> dict[str, Any]:
    """The JSON object in `path`, a run's metrics.json; a file that does not read as one is a damaged checkpoint
    (CorruptCheckpointError naming it, exit 2)."""
    return read_json_object(path, "the run's metrics", CorruptCheckpointError)


def load_params(
    checkpoint: Path, env: JaxEnv, network: NetworkSettings, data: bytes | None = None
) -> tuple[Any, RunningStatistics]:
    """A checkpoint's network parameters and observation normaliser (from `data`, its params file's bytes,
    when given), checked against the network's shapes; host arrays."""
    template = abstract_state(env, network=network, optimization=OptimizationSettings())
    target = {"params": template.params, "normalizer": template.normalizer._asdict()}
    path = checkpoint / PARAMS_FILE
    raw = _restore(path, payload_bytes(checkpoint, PARAMS_FILE) if data is None else data, None)  # the saved arrays
    if not isinstance(raw, dict) or _shapes(raw.get("params")) != _shapes(serialization.to_state_dict(template.params)):
        # msgpack restores any shapes; the network would fail deep inside flax (ScopeParamShapeError)
        raise NetworkMismatchError(
            f"{path} holds a network of other sizes than its config.json describes "
            f"(hidden_sizes {list(network.hidden_sizes)}); was the config edited?"
        )
    try:
        saved = serialization.from_state_dict(target, raw)
    except Exception as error:  # flax raises many types for a normaliser of another size
        raise CorruptCheckpointError(f"cannot load {path}: {type(error).__name__}: {error}") from None
    return saved["params"], RunningStatistics(**saved["normalizer"])


def _shapes(tree: Any) -> list[tuple[str, tuple[int, ...]]]:
    """Each array of a state dict: its path and shape."""
    leaves, _ = jax.tree_util.tree_flatten_with_path(tree)
    return [(jax.tree_util.keystr(path), tuple(getattr(leaf, "shape", ()))) for path, leaf in leaves]


def load_state(
    checkpoint: Path, env: JaxEnv, settings: PpoSettings, payloads: dict[str, bytes] | None = None
) -> tuple[TrainingState, Progress]:
    """The full training state of a checkpoint (environments freshly reset), for resuming; from `payloads`
    (`resume_payloads`, read by another process) when given. Every process of a run calls it together."""
    payloads = payloads or resume_payloads(checkpoint)
    template = abstract_state(env, network=settings.network, optimization=settings.optimization)
    params, normalizer = load_params(checkpoint, env, settings.network, payloads[PARAMS_FILE])
    target = {"opt_state": template.opt_state, "key": template.key, "iteration": 0, "env_steps": 0}
    saved = _restore(checkpoint / TRAIN_STATE_FILE, payloads[TRAIN_STATE_FILE], target)
    state = TrainingState(
        params, saved["opt_state"], normalizer, env.reset(jax.random.fold_in(saved["key"], 1)), saved["key"]
    )
    state = jax.device_put(state, jax.tree.map(lambda leaf: leaf.sharding, template))
    return state, Progress(int(saved["iteration"]), int(saved["env_steps"]))
