"""SB3 checkpoints in the core's run-folder layout (`joshua_core.runs`), and how one proves it was written here.

    <checkpoint_dir>/<run>/              config.json (trainer "sb3", algorithm, task, the TrainingConfig,
                                         versions), metrics.json, training_curves.png, tensorboard/
    <checkpoint_dir>/<run>_step_<N>/     one folder per checkpoint, published atomically
        model.zip                        SB3 model with optimizer state (unpickled on load)
        vecnormalize.pkl                 observation/reward normalisation statistics (unpickled on load)
        replay_buffer.pkl                SAC/TD3 only, newest checkpoint only (unpickled on load)
        config.json, metrics.json        copies, so one checkpoint folder stands on its own
        manifest.json                    SHA-256 of every file, signed with this user's checkpoint key

SB3 checkpoints unpickle on load, so loading one from an untrusted source runs its code. A
checkpoint is loaded only when its manifest carries a valid HMAC-SHA256 made with the key in
`~/.config/joshua/checkpoint.key` (created on first use, readable by its owner only; the
environment variable JOSHUA_CHECKPOINT_KEY_FILE points elsewhere) and every file it loads has the
hash the manifest lists, and so has its config.json (what the model is run with). Anything else (a
folder copied from another machine, a changed file, a folder not written by joshua-sb3) is refused unless
the user explicitly trusts it.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import secrets
from collections.abc import Callable
from pathlib import Path
from typing import Any

from joshua_core.atomic import atomic_create_bytes, atomic_write_json, json_safe
from joshua_core.curves import write_training_curves
from joshua_core.errors import UsageError
from joshua_core.json_files import read_json_object
from joshua_core.runs import CONFIG_FILE, METRICS_FILE, RunFolder
from joshua_core.tasks import METRIC_PREFIX

CURVES_FILE = "training_curves.png"
MANIFEST_FILE = "manifest.json"
MODEL_FILE = "model.zip"
NORMALIZATION_FILE = "vecnormalize.pkl"
REPLAY_BUFFER_FILE = "replay_buffer.pkl"
MANIFEST_FORMAT = "joshua-sb3-checkpoint/1"
KEY_ENV_VAR = "JOSHUA_CHECKPOINT_KEY_FILE"
KEY_BYTES = 32


class UntrustedCheckpointError(UsageError):
    """A checkpoint that this machine's user did not write (or that changed since) was not loaded."""


def key_path() -> Path:
    """Where this user's checkpoint signing key lives."""
    if os.environ.get(KEY_ENV_VAR):
        return Path(os.environ[KEY_ENV_VAR]).expanduser()
    config_home = Path(os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config")
    return config_home / "joshua" / "checkpoint.key"


def signing_key(*, create: bool) -> bytes | None:
    """This user's secret key; created (mode 0600) when `create` and missing, else None when missing."""
    path = key_path()
    if path.is_dir():
        raise UsageError(f"checkpoint key {path} is a folder; set {KEY_ENV_VAR} to a file's path (made if missing)")
    if not path.exists() and create:
        # whole or not at all: created and then written, a key read by a run starting beside this one could be
        # empty, which stopped that run ("shorter than 32 bytes"); a run that loses the race uses the winner's
        atomic_create_bytes(path, secrets.token_bytes(KEY_BYTES))
    if not path.exists():
        return None
    key = path.read_bytes()
    if len(key) < KEY_BYTES:
        raise UsageError(f"checkpoint key {path} is shorter than {KEY_BYTES} bytes; delete it to make a new one")
    return key


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _signature(key: bytes, manifest: dict[str, Any]) -> str:
    unsigned = {name: value for name, value in manifest.items() if name != "signature"}
    return hmac.new(key, json.dumps(unsigned, sort_keys=True).encode(), hashlib.sha256).hexdigest()


def write_checkpoint(
    run: RunFolder, step: int, save: Callable[[Path], None], documents: dict[str, Any], *, keep_replay_buffer: bool
) -> Path:
    """Write checkpoint `step` atomically: `save(folder)` writes the model files, `documents` the JSON files.

    Every file is hashed into a signed manifest. Older checkpoints lose their replay buffer unless
    `keep_replay_buffer` (it is large, and only the newest one is needed to resume).
    """
    key = signing_key(create=True)
    assert key is not None
    with run.publish(step) as folder:
        save(folder)
        for name, document in documents.items():
            (folder / name).write_text(json.dumps(document, indent=2, sort_keys=True) + "\n", encoding="utf-8")
        files = {path.name: _sha256(path) for path in sorted(folder.iterdir())}
        manifest: dict[str, Any] = {"format": MANIFEST_FORMAT, "step": step, "files": files}
        manifest["signature"] = _signature(key, manifest)
        (folder / MANIFEST_FILE).write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    if not keep_replay_buffer:
        for older in run.checkpoints()[:-1]:
            (older / REPLAY_BUFFER_FILE).unlink(missing_ok=True)
    return run.checkpoint_path(step)


def verify_checkpoint(checkpoint: Path, names: list[str], *, trust: bool, trust_hint: str) -> None:
    """Refuse to go on unless the files `names` of `checkpoint` were written by this user and are unchanged."""
    missing = [name for name in names if not (checkpoint / name).is_file()]
    if missing:
        raise UsageError(f"checkpoint '{checkpoint}' is incomplete: missing {', '.join(missing)}")
    if trust:
        return
    reason = _untrusted_reason(checkpoint, names)
    if reason:
        raise UntrustedCheckpointError(
            f"refusing to load checkpoint '{checkpoint}': {reason}. Its {' and '.join(names)} run code when "
            f"loaded (pickle), so only checkpoints written by this user on this machine are loaded. "
            f"If you trust where it came from: {trust_hint}"
        )


def _untrusted_reason(checkpoint: Path, names: list[str]) -> str | None:
    """Why the checkpoint cannot be trusted, or None when its signature and file hashes check out."""
    manifest_path = checkpoint / MANIFEST_FILE
    if not manifest_path.is_file():
        return f"it has no {MANIFEST_FILE}, so joshua-sb3 did not write it"
    try:
        manifest = read_json_object(manifest_path, "the checkpoint's manifest")
    except UsageError as error:
        return str(error)
    if manifest.get("format") != MANIFEST_FORMAT:
        return f"its {MANIFEST_FILE} is not a {MANIFEST_FORMAT} manifest"
    key = signing_key(create=False)
    if key is None:
        return f"this machine has no checkpoint key ({key_path()}), so it was written elsewhere"
    if not hmac.compare_digest(str(manifest.get("signature", "")), _signature(key, manifest)):
        return f"its signature does not match this user's checkpoint key ({key_path()}): it was written elsewhere"
    for name in [*names, CONFIG_FILE]:  # config.json: what the loaded model is run with (task, environments)
        path = checkpoint / name
        if not path.is_file() or manifest.get("files", {}).get(name) != _sha256(path):
            return f"{name} changed after it was written"
    return None


def update_run_metrics(run_dir: Path, metrics: dict[str, Any], *, title: str) -> None:
    """Rewrite the run's metrics.json and its training-curve PNG (atomically)."""
    atomic_write_json(run_dir / METRICS_FILE, json_safe(metrics))  # a NaN loss is written as null
    series = ["rollout/ep_rew_mean"] + sorted(
        {name for record in metrics["history"] for name in record if name.startswith(METRIC_PREFIX)}
    )
    write_training_curves(metrics["history"], run_dir / CURVES_FILE, title=title, series=series)
