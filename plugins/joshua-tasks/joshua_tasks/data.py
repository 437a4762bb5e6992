"""The data folder joshua-tasks ships: the robot models its tasks run on (`models/`) and the presets (`presets/`).

Both stay at the repository's top level, where users' paths and the docs name them; the wheel force-includes them
into this package (pyproject.toml). So an installed wheel finds them beside this module, a source checkout two
folders above the distribution's.
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent

ROOT = _PACKAGE if (_PACKAGE / "models").is_dir() else _PACKAGE.parents[2]
