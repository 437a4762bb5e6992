"""Where JOSHUA writes: names that become paths, writes kept inside their folder, folders it may replace.

Compiled programs and other per-user state that a run may rebuild live in `user_cache_dir()`. Whether a program
may use it is one switch, `--no-cache` or `JOSHUA_NO_CACHE=1` (`cache_enabled()`): the core declares and sets it,
and the plugins that keep compiled programs there (joshua-jax) read it, so the core knows no compiler's cache.

A name the user chooses for something JOSHUA creates (a run, an output folder, an output file) is one plain
path component, so that it cannot lead outside the folder it is made in. A folder JOSHUA writes whole (a
dataset, an export) carries `MARKER`; a folder is only ever replaced when it carries the marker and the user
asked for it (`--overwrite`): JOSHUA never deletes what it did not make.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from joshua_core.atomic import atomic_directory
from joshua_core.errors import UsageError

CACHE_HOME_ENV_VAR = "XDG_CACHE_HOME"
NO_CACHE_ENV_VAR = "JOSHUA_NO_CACHE"  # set, the caches in user_cache_dir() are neither read nor kept
MARKER = ".joshua-output"  # in every folder JOSHUA writes whole: what tells it apart from the user's folders
MAX_NAME_BYTES = 255  # the longest file name Linux and macOS file systems take
_SHOWN = 60  # characters of a refused name that the message shows


def user_cache_dir() -> Path:
    """This user's cache folder for JOSHUA: `$XDG_CACHE_HOME/joshua`, else `~/.cache/joshua` (the XDG Base
    Directory rule, so that users and cleaners find it where they find other programs' caches)."""
    home = Path(os.environ.get(CACHE_HOME_ENV_VAR, "")).expanduser()
    base = home if home.is_absolute() else Path.home() / ".cache"  # the rule: a relative path is ignored
    return base / "joshua"


def cache_enabled() -> bool:
    """False when JOSHUA_NO_CACHE is set to anything but '', '0', 'false' or 'no' (what --no-cache sets)."""
    return os.environ.get(NO_CACHE_ENV_VAR, "").strip().lower() in ("", "0", "false", "no")


def add_no_cache_argument(parser: argparse.ArgumentParser) -> None:
    """Declare `--no-cache`, the way every command that compiles takes it; `apply_no_cache` acts on it."""
    parser.add_argument(
        "--no-cache",
        action="store_true",
        help=f"neither read nor keep compiled programs in {user_cache_dir()} (same as {NO_CACHE_ENV_VAR}=1)",
    )


def apply_no_cache(args: argparse.Namespace) -> None:
    """With `--no-cache`, turn caching off for this process and the processes it starts (through the variable)."""
    if args.no_cache:
        os.environ[NO_CACHE_ENV_VAR] = "1"


def check_name(name: str, what: str) -> str:
    """`name` when it is one plain path component; else a UsageError naming `what` (e.g. "--run-name")."""
    problem = None
    if not name:
        problem = "is empty"
    elif name in (".", ".."):
        problem = "is not a name of its own"
    elif "/" in name or "\\" in name:
        problem = "holds a '/' or '\\'"
    elif "\0" in name:
        problem = "holds a NUL byte"
    elif len(os.fsencode(name)) > MAX_NAME_BYTES:
        problem = f"is {len(os.fsencode(name))} bytes long (at most {MAX_NAME_BYTES})"
    if problem is not None:
        shown = name if len(name) <= _SHOWN else name[:_SHOWN] + "..."
        raise UsageError(f"{what} {shown!r} {problem}: give one plain file or folder name")
    return name


def check_inside(folder: Path, path: Path, what: str) -> Path:
    """`path`, after checking that it leads inside `folder` once both are resolved (symbolic links followed);
    a UsageError naming `what` otherwise."""
    base, resolved = folder.resolve(), path.resolve()
    if resolved != base and base not in resolved.parents:
        raise UsageError(f"{what} '{path}' leads outside {folder} (to {resolved})")
    return path


def check_replaceable(path: Path, *, overwrite: bool, option: str) -> Path:
    """`path`, after checking that a folder JOSHUA writes whole may go there: nothing there, an empty folder, or
    (with `overwrite`) a folder carrying `MARKER`. Anything else is a one-line UsageError naming `option`."""
    if path.name in ("", ".", ".."):
        raise UsageError(f"{option} '{path}' names no folder of its own; give a new folder's path")
    check_name(path.name, option)
    if path.is_symlink():
        raise UsageError(f"{option} '{path}' is a symbolic link; give the path of a folder")
    if not path.exists():
        return path
    if not path.is_dir():
        raise UsageError(f"{option} '{path}' is a file; give the path of a folder")
    if not any(path.iterdir()):
        return path
    if not (path / MARKER).is_file():
        raise UsageError(
            f"{option} '{path}' exists and was not written by joshua (it has no {MARKER}); "
            "choose another path or move it away"
        )
    if not overwrite:
        raise UsageError(f"{option} '{path}' exists; pass --overwrite to replace it")
    return path


@contextmanager
def output_folder(path: Path, *, overwrite: bool, option: str) -> Iterator[Path]:
    """Yield an empty temporary folder holding `MARKER`; when the block ends without error it becomes `path`
    (`atomic_directory`). `path` is checked (`check_replaceable`) before the block and again before the swap,
    since the user may put something there while the folder is written."""
    check_replaceable(path, overwrite=overwrite, option=option)
    with atomic_directory(path) as folder:
        (folder / MARKER).write_text("written by joshua; joshua may replace this folder whole (--overwrite)\n")
        yield folder
        check_replaceable(path, overwrite=overwrite, option=option)
