"""Where shipped data lives: the robot models and presets that plugins ship, never the core.

A plugin registers each data folder it ships (`joshua_register_data_folders`): a folder holding `models/`, `presets/`
or both. Users and presets name those files by relative path or preset name, with no run at hand, so this module
asks the installed plugins (discovered once per process and JOSHUA_DISABLE_PLUGINS value) rather than a run's host.
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from pathlib import Path

from joshua_core import catalog
from joshua_core.errors import ModelError, PluginLoadError, UsageError
from joshua_core.kinds import Kind
from joshua_core.plugins import DISABLE_ENV_VAR, PluginHost

MODELS = "models"
PRESETS = "presets"


@dataclass(frozen=True)
class DataFolder:
    """One registered data folder and who ships it (for messages)."""

    path: Path
    owner: str


def data_folders(plugins: PluginHost) -> tuple[DataFolder, ...]:
    """The data folders `plugins` registered, in the order of their names; a target that is not an existing folder
    is a PluginLoadError naming the plugin."""
    folders = []
    for name in plugins.names(Kind.DATA):
        component = plugins.component(Kind.DATA, name)
        owner = f"data folder '{name}' from plugin '{component.plugin.name}' ({component.plugin.distribution})"
        target = component.load()
        if not (isinstance(target, Path) and target.is_dir()):
            raise PluginLoadError(f"{owner} is {target!r}, not the Path of an existing folder")
        folders.append(DataFolder(target.resolve(), owner))
    return tuple(folders)


@functools.cache
def _installed(disabled: str) -> tuple[DataFolder, ...]:
    return data_folders(PluginHost.discover(disabled.split(",")))


def installed_folders() -> tuple[DataFolder, ...]:
    """The data folders of the installed plugins, less those JOSHUA_DISABLE_PLUGINS names."""
    return _installed(os.environ.get(DISABLE_ENV_VAR, ""))


def data_dirs(name: str) -> tuple[Path, ...]:
    """Every shipped folder of data `name` (MODELS or PRESETS), in the order of the data folders' names."""
    return tuple(folder.path / name for folder in installed_folders() if (folder.path / name).is_dir())


def models_dir() -> Path:
    """The first shipped models folder (tests and benchmarks name the robots' files in it); none installed is a
    ModelError saying what to install."""
    found = data_dirs(MODELS)
    if not found:
        raise ModelError(f"no installed plugin ships robot models; {_install_hint()}")
    return found[0]


def _install_hint() -> str:
    """Which first-party distributions ship data folders, as a "pip install" hint."""
    shippers = sorted(set(catalog.provided(Kind.DATA).values()))
    return f"install one that does: pip install {' or '.join(shippers)}" if shippers else "install one that does"


def shipped_names(name: str, suffix: str) -> list[str]:
    """Sorted stems of the `suffix` files in every shipped folder of data `name` (e.g. the preset names)."""
    return sorted({path.stem for folder in data_dirs(name) for path in folder.glob(f"*{suffix}")})


def shipped_file(name: str, filename: str) -> Path | None:
    """The file `filename` in the shipped folders of data `name`, or None; two plugins shipping it is a one-line
    UsageError naming both."""
    found = [
        (folder.path / name / filename, folder.owner)
        for folder in installed_folders()
        if (folder.path / name / filename).is_file()
    ]
    if len(found) > 1:
        owners = " and ".join(owner for _, owner in found)
        raise UsageError(f"{name} file '{filename}' is shipped by both {owners}; disable one ({DISABLE_ENV_VAR})")
    return found[0][0] if found else None


def resolve_data_path(
    path: str | Path, *, base_dirs: tuple[Path, ...] = (), what: str = "model", folders: bool = False
) -> Path:
    """Find a file (or, with `folders`, a folder too: e.g. a dataset) given as written by a user or a preset.

    Absolute paths are taken as they are. A relative path is tried against each of `base_dirs`
    (e.g. the folder of the config file that named it), then the working directory, then each
    shipped models folder (with or without a leading `models/`). A miss raises ModelError naming
    every path tried, or the folder found where a file was wanted.
    """
    candidate = Path(path).expanduser()
    if candidate.is_absolute():
        tried = [candidate]
    else:
        tried = [base / candidate for base in base_dirs] + [Path.cwd() / candidate]
        for shipped in data_dirs(MODELS):
            tried.append(shipped / candidate)
            if candidate.parts[:1] == (MODELS,):
                tried.append(shipped.joinpath(*candidate.parts[1:]))
    for option in tried:
        if option.is_file() or (folders and option.is_dir()):
            return option.resolve()
    found_folders = [option for option in tried if option.is_dir()]
    if found_folders:
        raise ModelError(f"{what} '{path}' is a folder ({found_folders[0]}); give the path of a file")
    searched = "\n  ".join(str(option) for option in dict.fromkeys(tried))
    message = f"{what} file '{path}' not found; searched:\n  {searched}"
    if not candidate.is_absolute() and not data_dirs(MODELS):
        message += f"\n(no installed plugin ships robot models; {_install_hint()})"
    raise ModelError(message)
