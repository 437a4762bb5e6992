"""Loading model files: MJCF through MuJoCo, other formats (USD) through the `ModelReader` a plugin
registers for the file suffix. Every engine, environment and trainer loads its model here."""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

import mujoco

from joshua_core.errors import ModelError

if TYPE_CHECKING:
    from joshua_core.plugins import PluginHost

MJCF_SUFFIXES = frozenset({".xml", ".mjcf"})
_T = TypeVar("_T")
_warned: set[str] = set()


def _print_warning(message: str) -> None:
    """MuJoCo's warnings on stderr, each kind once per process: MuJoCo's own handler prints every one and
    appends it to MUJOCO_LOG.TXT in the working directory, a file nobody asked for (mujoco.batch calls this
    from its worker threads, for every simulation)."""
    kind = message.split(" Time = ")[0]  # the same warning at another time is not news
    if kind not in _warned:
        _warned.add(kind)
        print(f"mujoco: warning: {message}", file=sys.stderr)


mujoco.set_mju_user_warning(_print_warning)


def read_spec(path: Path, plugins: PluginHost | None = None) -> mujoco.MjSpec:
    """The MjSpec of the model file at `path` (absolute, as `resolve_data_path` gives it). A suffix other
    than MJCF's goes to the reader `plugins` (the run's host) registers for it; without a host only MJCF is read."""
    suffix = path.suffix.lower()
    if suffix in MJCF_SUFFIXES:
        return compiled(path, lambda: mujoco.MjSpec.from_file(str(path)))
    if plugins is None:
        raise ModelError(f"{path}: a '{suffix}' model is read by a plugin's model reader; pass the run's plugins")
    return plugins.model_reader(suffix).read(path)


def compile_model(
    model_path: Path | None,
    *,
    xml: str | None = None,
    assets: Mapping[str, bytes] | None = None,
    plugins: PluginHost | None = None,
) -> mujoco.MjModel:
    """Compile a model file (an existing path, as `resolve_data_path` gives it) or an MJCF string, turning
    MuJoCo's errors into ModelError that names the file."""
    if model_path is None:
        return compiled(Path("<xml string>"), lambda: mujoco.MjModel.from_xml_string(xml, dict(assets or {})))
    spec = read_spec(model_path, plugins)
    return compiled(model_path, spec.compile)


def compiled(path: Path, step: Callable[[], _T]) -> _T:
    """Run a MuJoCo parse or compile step, turning its errors into ModelError naming the file."""
    try:
        return step()
    except ValueError as error:
        raise ModelError(f"{path}: model does not compile: {error}") from None
