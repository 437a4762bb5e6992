"""Where the data shipped with joshua-core lives: models, presets.

An installed wheel carries them inside the package (`joshua_core/models`, `joshua_core/presets`);
a source checkout (editable install) keeps them at the repository's top level.
"""

from __future__ import annotations

from pathlib import Path

from joshua_core.errors import ModelError

_PACKAGE_DIR = Path(__file__).resolve().parent


def data_dir(name: str) -> Path:
    """Return the folder of shipped data `name` ("models" or "presets")."""
    packaged = _PACKAGE_DIR / name
    return packaged if packaged.is_dir() else _PACKAGE_DIR.parent / name


def models_dir() -> Path:
    """Folder of the shipped robot models; relative model paths resolve against it last."""
    return data_dir("models")


def presets_dir() -> Path:
    """Folder of the shipped `.pbtxt` presets."""
    return data_dir("presets")


def resolve_data_path(
    path: str | Path, *, base_dirs: tuple[Path, ...] = (), what: str = "model", folders: bool = False
) -> Path:
    """Find a file (or, with `folders`, a folder too: e.g. a dataset) given as written by a user or a preset.

    Absolute paths are taken as they are. A relative path is tried against each of `base_dirs`
    (e.g. the folder of the config file that named it), then the working directory, then the
    shipped models folder (with or without a leading `models/`). A miss raises ModelError naming
    every path tried, or the folder found where a file was wanted.
    """
    candidate = Path(path).expanduser()
    if candidate.is_absolute():
        tried = [candidate]
    else:
        shipped = models_dir()
        tried = [base / candidate for base in base_dirs] + [Path.cwd() / candidate, shipped / candidate]
        if candidate.parts[:1] == ("models",):
            tried.append(shipped.joinpath(*candidate.parts[1:]))
    for option in tried:
        if option.is_file() or (folders and option.is_dir()):
            return option.resolve()
    found_folders = [option for option in tried if option.is_dir()]
    if found_folders:
        raise ModelError(f"{what} '{path}' is a folder ({found_folders[0]}); give the path of a file")
    searched = "\n  ".join(str(option) for option in dict.fromkeys(tried))
    raise ModelError(f"{what} file '{path}' not found; searched:\n  {searched}")
