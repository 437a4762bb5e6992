"""Write joshua_core/providers.json: what each first-party plugin registers, read from its own hooks.

    python tools/provider_catalog.py      # after changing what a plugin in plugins/ registers

The core reads the catalog to say which distribution to install when a component is missing
(`joshua_core.catalog`); tests/test_plugins.py rebuilds it with `build()` and fails when the shipped file differs.
Needs every first-party plugin installed (./setup.sh --all), since it asks the plugins, not a copy of them.
"""

from __future__ import annotations

import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # run from a checkout: this tree's core, whatever is installed

from joshua_core.catalog import CATALOG_FILE, Catalog, catalog_of, catalog_text  # noqa: E402
from joshua_core.plugins import PluginHost  # noqa: E402


def first_party_plugins(root: Path = ROOT) -> list[str]:
    """The distributions in plugins/ that declare an entry point in the group `joshua` (libraries declare none)."""
    names = []
    for pyproject in sorted(root.glob("plugins/*/pyproject.toml")):
        project = tomllib.loads(pyproject.read_text(encoding="utf-8"))["project"]
        if "joshua" in project.get("entry-points", {}):
            names.append(project["name"])
    return names


def build(root: Path = ROOT) -> Catalog:
    """The catalog of the installed first-party plugins; one that is missing, disabled or broken is an error,
    since its registrations would silently drop out of the catalog."""
    host = PluginHost.discover(disabled=[])
    loaded = {info.distribution: info for info in host.plugins if not info.error}
    wanted = first_party_plugins(root)
    if absent := [name for name in wanted if name not in loaded]:
        problems = {info.distribution: info.error for info in host.plugins if info.error}
        raise SystemExit(f"not installed or broken: {', '.join(absent)} {problems or ''}; run ./setup.sh --all")
    return catalog_of(loaded[name] for name in wanted)


def main() -> int:
    CATALOG_FILE.write_text(catalog_text(build()), encoding="utf-8")
    print(f"wrote {CATALOG_FILE.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
