"""Atomic file writes: a crash mid-write leaves the previous file, never a truncated one.

Temporary names carry the writer's pid (`.NAME.<pid>.<random><suffix>`), so that a later writer of the same
path can remove what a killed one (SIGKILL cannot be caught) left behind, and nothing a live process owns.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any


def atomic_write_bytes(path: Path, payload: bytes) -> None:
    """Write `payload` to `path` through a temporary file in the same folder and an atomic rename.

    The file gets the permissions a plain `open()` would give it (0666 less the umask), not the
    owner-only ones of the temporary file.
    """
    temporary = _written_temporary(path, payload, 0o666 & ~_umask())
    try:
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def atomic_create_bytes(path: Path, payload: bytes) -> bool:
    """Create `path` holding `payload` unless a file is there already; True when this call created it. The file is
    written whole under a temporary name and hard-linked into place (which fails where the path exists), so a
    process racing this one finds no file or the whole file, never an empty one between creation and write.
    Owner-only permissions, as for a key."""
    temporary = _written_temporary(path, payload, None)
    try:
        os.link(temporary, path)
        return True
    except FileExistsError:
        return False
    finally:
        Path(temporary).unlink(missing_ok=True)


def _written_temporary(path: Path, payload: bytes, mode: int | None) -> str:
    """A temporary file beside `path` holding `payload`, on disk (owner-only, or `mode`); its name."""
    path.parent.mkdir(parents=True, exist_ok=True)
    descriptor, temporary = tempfile.mkstemp(dir=path.parent, prefix=temporary_prefix(path), suffix=".tmp")
    try:
        with os.fdopen(descriptor, "wb") as handle:
            if mode is not None:
                os.fchmod(handle.fileno(), mode)
            handle.write(payload)
            handle.flush()
            os.fsync(handle.fileno())
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    return temporary


def _umask() -> int:
    """The process's umask (reading it means setting it, so it is set straight back)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def atomic_write_json(path: Path, document: Any) -> None:
    """Write `document` as indented JSON, atomically. NaN and infinities are refused (ValueError), since
    `NaN`/`Infinity` are not JSON and break every strict reader: pass `json_safe(document)` where a value
    may legitimately be non-finite."""
    text = json.dumps(document, indent=2, sort_keys=True, allow_nan=False)
    atomic_write_bytes(path, (text + "\n").encode())


def json_safe(value: Any) -> Any:
    """A copy of `value` (dicts, lists, tuples, numbers) with each NaN or infinite float replaced by None (null)."""
    if isinstance(value, dict):
        return {key: json_safe(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(item) for item in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


@contextmanager
def atomic_directory(path: Path) -> Iterator[Path]:
    """Yield an empty temporary folder beside `path`; when the block ends without error, it becomes `path`,
    with the permissions a plain `mkdir` would give it (0777 less the umask).

    The files are flushed to disk before the rename, so a crash leaves either no `path` or a complete
    one (plus, at worst, a hidden `.NAME.*.tmp` folder). An existing `path` is replaced. On error the
    temporary folder is removed and `path` is untouched.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    for suffix in (".tmp", ".old"):
        remove_stale_temporaries(path, suffix)
    temporary = Path(tempfile.mkdtemp(dir=path.parent, prefix=temporary_prefix(path), suffix=".tmp"))
    try:
        os.chmod(temporary, 0o777 & ~_umask())  # what a plain mkdir gives, not mkdtemp's owner-only mode
        yield temporary
        for file in temporary.rglob("*"):
            if file.is_file():
                with open(file, "rb") as handle:
                    os.fsync(handle.fileno())
        if path.exists():
            stale = Path(tempfile.mkdtemp(dir=path.parent, prefix=temporary_prefix(path), suffix=".old"))
            os.replace(path, stale / path.name)
            os.replace(temporary, path)
            shutil.rmtree(stale)
        else:
            os.replace(temporary, path)
        _fsync_directory(path.parent)
    except BaseException:
        shutil.rmtree(temporary, ignore_errors=True)
        raise


def temporary_prefix(path: Path) -> str:
    """The start of the name of a temporary file or folder that this process writes to become `path`."""
    return f".{path.name}.{os.getpid()}."


def remove_stale_temporaries(path: Path, suffix: str) -> list[Path]:
    """Remove the temporaries of `path` (named `temporary_prefix(path)`...`suffix`) whose writer has died;
    returns them."""
    pattern = re.compile(rf"^\.{re.escape(path.name)}\.(\d+)\.[^.]+{re.escape(suffix)}$")
    removed = []
    for candidate in path.parent.iterdir() if path.parent.is_dir() else []:
        match = pattern.match(candidate.name)
        if match is None or _alive(int(match.group(1))):
            continue
        if candidate.is_dir() and not candidate.is_symlink():
            shutil.rmtree(candidate, ignore_errors=True)
        else:
            candidate.unlink(missing_ok=True)
        removed.append(candidate)
    return removed


def _alive(pid: int) -> bool:
    """Whether process `pid` exists (one of another user counts as alive: its files are not ours)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _fsync_directory(folder: Path) -> None:
    """Make a rename inside `folder` durable."""
    descriptor = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


STAGING_NAME = "staged"  # temporaries of `staged_outputs` are named after it


class Staging:
    """A hidden temporary folder inside `folder` that a run writes all its outputs into; `publish` moves them into
    `folder` together, each replacing the entry of its name. See `staged_outputs`."""

    def __init__(self, folder: Path, temporary: Path) -> None:
        self.folder = folder
        self.temporary = temporary

    def publish(self) -> None:
        """Flush the staged files to disk, then rename each staged entry into `folder` (a folder replaces the
        earlier one whole). Only these renames lie between the earlier outputs and the new ones."""
        for file in self.temporary.rglob("*"):
            if file.is_file():
                with open(file, "rb") as handle:
                    os.fsync(handle.fileno())
        retired = Path(tempfile.mkdtemp(dir=self.temporary, prefix=".retired."))
        for entry in sorted(self.temporary.iterdir()):
            if entry == retired:
                continue
            target = self.folder / entry.name
            if entry.is_dir() and target.is_dir() and not target.is_symlink():
                os.replace(target, retired / entry.name)  # a folder cannot replace a non-empty folder in one rename
            os.replace(entry, target)
        _fsync_directory(self.folder)


@contextmanager
def staged_outputs(folder: Path) -> Iterator[Staging]:
    """Yield a `Staging` inside `folder` (created if missing): a run writes its outputs into `staging.temporary`
    and calls `staging.publish()` once they are complete. Whatever is not published is removed when the block
    ends; a process killed before `publish` leaves `folder` as it was, plus a hidden `.staged.<pid>.*.tmp`
    folder that the next call removes."""
    folder.mkdir(parents=True, exist_ok=True)
    name = folder / STAGING_NAME
    remove_stale_temporaries(name, ".tmp")
    temporary = Path(tempfile.mkdtemp(dir=folder, prefix=temporary_prefix(name), suffix=".tmp"))
    try:
        yield Staging(folder, temporary)
    finally:
        shutil.rmtree(temporary, ignore_errors=True)
