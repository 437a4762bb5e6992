"""Compiled programs kept between runs, so that a rerun of the same config starts warm.

JAX's persistent compilation cache and Warp's kernel cache both go to this user's cache folder
(`joshua_core.outputs.user_cache_dir()`: `jax/` and `warp/` in it). What JAX and Warp do with an entry
they cannot read is their documented behaviour, relied on here: JAX warns and compiles anew
(`jax_raise_persistent_cache_errors` is off by default), Warp rebuilds a kernel whose cached module is missing.
The core's switch turns both off (`--no-cache` on the command line, or `JOSHUA_NO_CACHE=1`:
`joshua_core.outputs.cache_enabled`); a cache folder the user already gave JAX (`JAX_COMPILATION_CACHE_DIR`,
`jax_compilation_cache_dir`) or Warp (`WARP_CACHE_PATH`) is kept.

Backends and trainers that compile call `use_compile_cache()` before their first compilation; it imports JAX
(and Warp, where it is installed) only then, so importing this module loads neither.
"""

from __future__ import annotations

import contextlib
import fcntl
import functools
import importlib.util
import os
import sys
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from joshua_core.outputs import NO_CACHE_ENV_VAR, cache_enabled, user_cache_dir

WARP_CACHE_ENV_VAR = "WARP_CACHE_PATH"  # Warp's own setting, read by warp.init()
BUILD_LOCK = "joshua-build.lock"  # the file `building_into` locks in a cache folder
ENTRY_SUFFIX = "-cache"  # how JAX names a cached program's file
# Every program is kept: JAX keeps only programs that took 1 s to compile by default, but a run compiles dozens
# that take less (resets, the normaliser, evaluation rollouts), and together they make up the warm start.
MIN_COMPILE_SECONDS = 0.0
MIN_ENTRY_BYTES = -1  # JAX: no size threshold, and none chosen for the file system either
_EVENTS: Counter[str] = Counter()  # JAX's compilation-cache events in this process (hits, requests)
_HIT = "/jax/compilation_cache/cache_hits"
_REQUEST = "/jax/compilation_cache/compile_requests_use_cache"


@dataclass(frozen=True)
class CompileCache:
    """Where this process keeps JAX's compiled programs (None: caching off) and how many were there at the start."""

    folder: Path | None
    programs: int

    def describe(self) -> str:
        """'compilation cache warm: FOLDER', 'cold' when it held no program, or 'off'."""
        if self.folder is None:
            return f"compilation cache off ({NO_CACHE_ENV_VAR})"
        return f"compilation cache {'warm' if self.programs else 'cold'}: {self.folder}"


def use_compile_cache() -> CompileCache:
    """Point JAX (and Warp, when installed) at this user's cache folder, or turn their caches off; call it before
    the first compilation. Calling it again changes nothing."""
    import jax

    _count_cache_events()
    enabled = cache_enabled()
    jax.config.update("jax_enable_compilation_cache", enabled)
    _use_warp_cache(enabled)
    if not enabled:
        return CompileCache(None, 0)
    folder = jax.config.values["jax_compilation_cache_dir"]  # one the user gave (JAX_COMPILATION_CACHE_DIR) is kept
    if not folder:
        folder = str(user_cache_dir() / "jax")
        jax.config.update("jax_compilation_cache_dir", folder)
    thresholds = {
        "jax_persistent_cache_min_compile_time_secs": MIN_COMPILE_SECONDS,
        "jax_persistent_cache_min_entry_size_bytes": MIN_ENTRY_BYTES,
    }
    for option, value in thresholds.items():
        if option.upper() not in os.environ:  # a threshold the user gave JAX (its variable) wins
            jax.config.update(option, value)
    path = Path(folder)
    programs = sum(1 for _ in path.glob(f"*{ENTRY_SUFFIX}")) if path.is_dir() else 0
    return CompileCache(path, programs)


@contextlib.contextmanager
def building_into(folder: Path | None, what: str) -> Iterator[None]:
    """Hold this host's lock on the cache `folder` while building into it (None: no cache, no lock).

    Runs started together on one host (a seed per GPU) compile the same programs: each alone takes every core,
    so side by side each takes several times as long as one alone. Under the lock one builds while the
    others wait, then read what it built. A folder the lock cannot be made in is built into without it."""
    if folder is None:
        yield
        return
    try:
        folder.mkdir(parents=True, exist_ok=True)
        lock = (folder / BUILD_LOCK).open("a")
    except OSError:
        yield
        return
    with lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            print(f"joshua: waiting for another process on this host building {what} into {folder}", flush=True)
            fcntl.flock(lock, fcntl.LOCK_EX)
        yield  # the lock goes with the file's closing


def cache_reads() -> tuple[int, int]:
    """(programs read from the cache, programs asked of it) in this process so far; compare two readings."""
    return _EVENTS[_HIT], _EVENTS[_REQUEST]


@functools.cache  # once per process: a listener cannot be removed, a second would count every event twice
def _count_cache_events() -> None:
    """Count JAX's compilation-cache events in _EVENTS."""
    import jax

    jax.monitoring.register_event_listener(lambda event, **_: _EVENTS.update((event,)))


def _use_warp_cache(enabled: bool) -> None:
    """Warp's kernels in `warp/` of the cache folder, or its cache off; nothing when Warp is not installed.
    Warp reads its settings when it initialises (`wp.init()`, at its first kernel): before that they take."""
    if "warp" not in sys.modules and importlib.util.find_spec("warp") is None:
        return
    import warp

    if not enabled:
        warp.config.cache_kernels = False
    elif warp.config.kernel_cache_dir is None and WARP_CACHE_ENV_VAR not in os.environ:
        warp.config.kernel_cache_dir = str(user_cache_dir() / "warp")
