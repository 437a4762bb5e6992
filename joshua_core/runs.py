"""Run folders, one layout for every trainer: unique names, a lock while training, atomic checkpoints.

    <checkpoint_dir>/<run>/            the run's own folder: config.json, metrics.json, curves, logs, videos,
                                       and .lock (held by the process training the run)
    <checkpoint_dir>/<run>_step_<N>/   one folder per checkpoint (what is in it is the trainer's business)

A run folder appears already locked: it is made as a hidden folder beside, its lock file taken and
its holder's pid written, and only then renamed to its name (a rename never replaces a folder that
holds files), so two processes never share a run and a second one asking for a name in use learns
which process holds it. A checkpoint is written into a hidden folder beside, flushed to disk and
renamed into place (`joshua_core.atomic.atomic_directory`): every visible checkpoint is complete.
A run killed before it wrote anything leaves its folder holding only the lock file with its pid; the lock
itself went with the process, so the next run of that name takes the folder over (saying so).
"""

from __future__ import annotations

import argparse
import errno
import fcntl
import os
import re
import secrets
import shutil
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from joshua_core.atomic import atomic_directory
from joshua_core.errors import ConfigError, UsageError
from joshua_core.json_files import read_json_object
from joshua_core.outputs import MARKER, check_inside, check_name

if TYPE_CHECKING:
    from joshua_core.config_pb2 import TrainingConfig

CONFIG_FILE = "config.json"  # in a run folder and each of its checkpoints: "trainer" names who wrote it
METRICS_FILE = "metrics.json"
LOCK_FILE = ".lock"
MAX_SUFFIX = 999  # default names taken in one second before giving up
_STEP_SUFFIX = re.compile(r"_step_(\d+)$")
CHECKPOINTS_PER_RUN = 10  # a run that names no checkpoint interval publishes this many checkpoints


def checkpoint_interval(requested: int, total_timesteps: int) -> int:
    """Steps between checkpoints: `requested`, else (0) total_timesteps / CHECKPOINTS_PER_RUN, at least 1."""
    return requested or max(1, total_timesteps // CHECKPOINTS_PER_RUN)


class RunInUseError(UsageError):
    """Another process holds the run's lock: it is training that run now."""


class RunFolder:
    """A run being trained: `<root>/<name>/`, locked by this process until `close()`, and its checkpoints."""

    def __init__(self, root: Path, name: str, lock: int) -> None:
        self.root = root
        self.name = name
        self._lock: int | None = lock

    @property
    def path(self) -> Path:
        return self.root / self.name

    def checkpoint_path(self, step: int) -> Path:
        return self.root / f"{self.name}_step_{step}"

    def checkpoints(self) -> list[Path]:
        """The run's checkpoint folders, oldest (fewest steps) first."""
        return run_checkpoints(self.root, self.name)

    @contextmanager
    def publish(self, step: int) -> Iterator[Path]:
        """Yield an empty hidden folder to write checkpoint `step` into; it appears as a whole when the block
        ends without error, and not at all otherwise. Hidden folders left by a killed writer are removed."""
        with atomic_directory(self.checkpoint_path(step)) as folder:
            yield folder
            (folder / MARKER).write_text(f"a checkpoint of run {self.name}, written whole by joshua\n")
        leftovers = re.compile(rf"^\.{re.escape(self.name)}_step_\d+\..+\.(tmp|old)$")
        for leftover in self.root.iterdir():
            if leftovers.match(leftover.name):
                shutil.rmtree(leftover, ignore_errors=True)

    def close(self) -> None:
        """Release the lock (the lock file stays: it is how the next holder is found)."""
        if self._lock is not None:
            os.close(self._lock)
            self._lock = None

    def __enter__(self) -> RunFolder:
        return self

    def __exit__(self, error_type: type[BaseException] | None, *_: object) -> None:
        """Release the lock; a block that failed before writing anything into the run leaves no folder."""
        if error_type is not None and [path.name for path in self.path.iterdir()] == [LOCK_FILE]:
            if not self.checkpoints():
                shutil.rmtree(self.path, ignore_errors=True)
        self.close()


def check_run_name(name: str, what: str) -> str:
    """`name` when it can name a run: one plain path component (`check_name`) that does not end in `_step_<N>`,
    the names of checkpoints; a one-line UsageError naming `what` (e.g. "--run-name") otherwise. Callers check
    the name they were given before any work."""
    check_name(name, what)
    if _STEP_SUFFIX.search(name):
        raise UsageError(f"{what} '{name}' ends in _step_<N>, as the run's checkpoints are named; choose another name")
    return name


def default_run_name(stem: str, now: datetime | None = None) -> str:
    """`<stem>_<date>-<time>` (the stem is the task, for PPO): the name of a run the config does not name."""
    return f"{stem}_{now or datetime.now():%Y%m%d-%H%M%S}"


def create_run(root: Path, name: str | None, *, stem: str, options: str) -> RunFolder:
    """A new run folder, locked by this process. `name` None: `default_run_name(stem)`, with `_2`, `_3`...
    when that is taken.

    A name the config chose that exists is a ConfigError (or a RunInUseError while a process trains it);
    `options` is where the config's run options live ("training"), or the command-line option that
    names the run (e.g. "--run-name": such runs are never continued), for the hint.
    """
    root.mkdir(parents=True, exist_ok=True)
    if name is not None:
        check_run_name(name, "run name")
        run = None if run_checkpoints(root, name) else _claim(root, name) or _take_over(root, name)
        if run is None:
            if (root / name / LOCK_FILE).is_file():  # a run's folder; no lock file is added to any other
                open_run(root, name).close()  # raises RunInUseError while another process trains it
            resume = "" if options.startswith("--") else f"continue it with --set {options}.resume=true, or "
            raise ConfigError(f"run folder {root / name} exists; {resume}choose another {_name_option(options)}")
        return run
    base = default_run_name(stem)
    for candidate in (base, *(f"{base}_{number}" for number in range(2, MAX_SUFFIX + 1))):
        run = None if run_checkpoints(root, candidate) else _claim(root, candidate)
        if run is not None:
            return run
    raise UsageError(f"{root} holds runs {base} to {base}_{MAX_SUFFIX}; name the run with {_name_option(options)}")


def _name_option(options: str) -> str:
    """The option that names a run: the command-line option itself, or the config's `<options>.run_name`."""
    return options if options.startswith("--") else f"{options}.run_name"


def open_run(root: Path, name: str) -> RunFolder:
    """An existing run folder, locked by this process (to resume it); RunInUseError while another holds it."""
    folder = check_inside(root, root / check_run_name(name, "run name"), "run folder")
    if not folder.is_dir():
        raise UsageError(f"run folder '{folder}' does not exist")
    descriptor = os.open(folder / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        _lock(descriptor, root, name)
    except BaseException:
        os.close(descriptor)
        raise
    return RunFolder(root, name, descriptor)


def _claim(root: Path, name: str) -> RunFolder | None:
    """Make `<root>/<name>` with its lock already held, or None when that name exists."""
    temporary = root / f".{name}.{secrets.token_hex(6)}.new"
    temporary.mkdir()  # with the mode a plain mkdir gives (mkdtemp's is owner-only)
    descriptor = os.open(temporary / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        _lock(descriptor, root, name)
        try:
            os.rename(temporary, root / name)  # fails on a folder holding files: every run folder does
        except OSError as error:
            if error.errno not in (errno.EEXIST, errno.ENOTEMPTY):
                raise
            os.close(descriptor)
            shutil.rmtree(temporary, ignore_errors=True)
            return None
    except BaseException:
        os.close(descriptor)
        shutil.rmtree(temporary, ignore_errors=True)
        raise
    return RunFolder(root, name, descriptor)


def _take_over(root: Path, name: str) -> RunFolder | None:
    """The existing folder `<root>/<name>`, locked by this process, when all it holds is the lock file of a run
    that ended before writing anything (killed while starting): `_claim` made it so, nothing else is in it, and
    its process is gone, since the lock is free; said in one line. None when the folder holds anything else (it
    is left as it is); RunInUseError while the process that holds the lock lives."""
    folder = root / name
    ended = _sole_lock_holder(folder)
    if ended is None:
        return None
    run = open_run(root, name)
    if _sole_lock_holder(folder) is None:  # looked at again under the lock: a process that had it wrote something
        run.close()
        return None
    print(
        f"joshua: warning: run folder {folder} held only the lock of process {ended}, which ended before writing "
        "anything; this run starts afresh in it",
        file=sys.stderr,
    )
    return run


def _sole_lock_holder(folder: Path) -> str | None:
    """The pid the lock file of `folder` names when that file is all the folder holds and reads as `_lock` writes
    it; None otherwise."""
    try:
        if [path.name for path in folder.iterdir()] != [LOCK_FILE]:
            return None
        content = (folder / LOCK_FILE).read_bytes()
    except OSError:
        return None
    return _holder(content) if re.fullmatch(rb"\d+\n", content) else None


def _holder(lock_content: bytes) -> str:
    """The process a lock file names (the pid `_lock` wrote), as text for a message."""
    return lock_content[:32].decode(errors="replace").strip() or "unknown"


def _lock(descriptor: int, root: Path, name: str) -> None:
    """Take the run's lock without waiting and write this process's pid into it; RunInUseError when held."""
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = _holder(os.pread(descriptor, 32, 0))
        raise RunInUseError(
            f"run '{name}' in {root} is being trained by process {holder}; wait for it to end, or choose another "
            "run_name"
        ) from None
    os.ftruncate(descriptor, 0)
    os.pwrite(descriptor, f"{os.getpid()}\n".encode(), 0)
    os.fsync(descriptor)


def checkpoint_step(folder: Path) -> int:
    """N of a checkpoint folder `<run>_step_<N>`."""
    match = _STEP_SUFFIX.search(folder.name)
    if match is None:
        raise UsageError(f"'{folder}' is not a checkpoint folder (<run>_step_<N>)")
    return int(match.group(1))


def run_checkpoints(root: Path, name: str) -> list[Path]:
    """The checkpoints `<root>/<name>_step_<N>/` that were published (`RunFolder.publish` leaves `MARKER` in
    each; of a run written before it did, those with a config.json), oldest first: a folder merely named like
    one is not a checkpoint."""
    pattern = re.compile(rf"^{re.escape(name)}_step_\d+$")
    if not root.is_dir():
        return []
    folders = [path for path in root.iterdir() if pattern.match(path.name) and path.is_dir()]
    published = [folder for folder in folders if (folder / MARKER).is_file()]
    return sorted(published or [folder for folder in folders if (folder / CONFIG_FILE).is_file()], key=checkpoint_step)


def list_runs(root: Path, trainer: str | None = None) -> list[Path]:
    """The run folders in `root` (those with a config.json, not checkpoints), of `trainer` when given, oldest
    first."""
    runs = []
    for config in root.glob(f"*/{CONFIG_FILE}") if root.is_dir() else []:
        if config.parent.name.startswith(".") or _STEP_SUFFIX.search(config.parent.name):
            continue  # a checkpoint, or one being written
        if trainer is None or _trainer_of(config) == trainer:
            runs.append(config.parent)
    return sorted(runs, key=lambda run: (run / CONFIG_FILE).stat().st_mtime)


def newest_run(root: Path, trainer: str | None = None) -> Path | None:
    """The run folder whose config.json was written last (of `trainer` when given), or None."""
    runs = list_runs(root, trainer)
    return runs[-1] if runs else None


def resume_run(root: Path, name: str | None, *, trainer: str, options: str) -> tuple[RunFolder, dict[str, Any]]:
    """The run to resume (the named one, else the newest of `trainer`), locked, and its config.json."""
    folder = root / check_run_name(name, "run name") if name else newest_run(root, trainer)
    if folder is None or not (folder / CONFIG_FILE).is_file():
        if folder is not None and (holder := _sole_lock_holder(folder)) is not None:
            raise ConfigError(
                f"{options}.resume: run folder {folder} holds nothing to resume (only the lock of process {holder}, "
                "which wrote nothing): start the run without resume"
            )
        which = f"no run '{name}'" if name else f"no {trainer} run"
        raise ConfigError(f"{options}.resume: there is {which} in {root} to resume")
    saved = read_run_config(folder)
    if saved["trainer"] != trainer:
        raise ConfigError(f"{options}.resume: run {folder} was trained by '{saved['trainer']}', not '{trainer}'")
    return open_run(root, folder.name), saved


def add_checkpoint_arguments(parser: argparse.ArgumentParser) -> None:
    """The `run` argument and `--trust-checkpoint` of the commands that load a run's checkpoint (eval, export)."""
    parser.add_argument("run", type=Path, help="run folder (its last checkpoint) or one checkpoint folder")
    parser.add_argument(
        "--trust-checkpoint",
        action="store_true",
        help="load a run folder written by someone else (its files may run code when loaded: trust it first)",
    )


def resolve_checkpoint(path: Path) -> Path:
    """A checkpoint folder itself, or the newest checkpoint of the run folder `path` (`run_checkpoints`: stray
    folders merely named like a checkpoint are skipped)."""
    if _STEP_SUFFIX.search(path.name) and (path / CONFIG_FILE).is_file():
        return path
    read_run_config(path)  # a clear error when `path` is neither
    checkpoints = run_checkpoints(path.parent, path.name)
    if not checkpoints:
        raise UsageError(f"run '{path}' has no checkpoint yet (looked for {path.parent}/{path.name}_step_<N>/)")
    return checkpoints[-1]


def read_run_config(run_dir: Path) -> dict[str, Any]:
    """The `config.json` of a run or checkpoint folder; a folder without a readable one is a UsageError."""
    path = run_dir / CONFIG_FILE
    if run_dir.exists() and not run_dir.is_dir():
        raise UsageError(f"'{run_dir}' is a file, not a run folder: give the folder a training run wrote")
    if not run_dir.is_dir():
        raise UsageError(f"run folder '{run_dir}' does not exist")
    if not path.is_file():
        raise UsageError(f"'{run_dir}' is not a run folder: it has no {CONFIG_FILE} (training runs write one)")
    document = read_json_object(path, "the run's config")
    if not isinstance(document.get("trainer"), str):
        raise UsageError(f'{path}: has no "trainer" entry naming the trainer that wrote the run')
    return document


def saved_training(run_dir: Path, run_format: str, options: Any) -> tuple[Path, dict[str, Any], TrainingConfig]:
    """The checkpoint of a run folder (its newest) or checkpoint folder, its config.json and the training config
    in it (`options`: the installed plugin options, `PluginHost.options()`); a config.json of another format or
    with an unreadable training config is a one-line UsageError (exit 2). Trainers' evaluate and export use it."""
    from google.protobuf import json_format

    from joshua_core.config_pb2 import TrainingConfig
    from joshua_core.options import parse_dict

    checkpoint = resolve_checkpoint(run_dir)
    saved = read_run_config(checkpoint)
    if saved.get("format") != run_format:
        raise UsageError(f"{checkpoint / CONFIG_FILE} is not a {run_format} run config")
    training = TrainingConfig()
    try:
        parse_dict(saved["training"], training, options)
    except (KeyError, json_format.ParseError) as error:
        raise UsageError(f"{checkpoint / CONFIG_FILE}: unreadable training config: {error}") from None
    return checkpoint, saved, training


def _trainer_of(config: Path) -> str | None:
    """The trainer a run's config.json names; None where it names none or does not read (not a run to list)."""
    try:
        return read_json_object(config, "the run's config").get("trainer")
    except UsageError:
        return None
