"""Which first-party distribution provides each component, for "pip install ..." hints when it is missing.

A missing plugin cannot say what it would have registered, so the core ships `providers.json`, a catalog
written from the first-party plugins' own registrations (their hooks, the one declaration) by
`python tools/provider_catalog.py`. `tests/test_plugins.py` rebuilds it from the installed plugins and fails
when it differs, so a registration without its hint, or a hint for something no plugin registers, fails the tests.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from joshua_core.kinds import Kind

if TYPE_CHECKING:
    from joshua_core.plugins import PluginInfo

CATALOG_FILE = Path(__file__).with_name("providers.json")

# distribution -> kind value -> sorted names, as providers.json holds it
Catalog = dict[str, dict[str, list[str]]]


@functools.cache
def _index() -> dict[tuple[Kind, str], str]:
    catalog: Catalog = json.loads(CATALOG_FILE.read_text(encoding="utf-8"))
    return {
        (Kind(kind), name): distribution
        for distribution, provided in catalog.items()
        for kind, names in provided.items()
        for name in names
    }


def provider(kind: Kind, name: str) -> str | None:
    """The first-party distribution that registers `name` of `kind`, or None."""
    return _index().get((kind, name))


def provided(kind: Kind) -> dict[str, str]:
    """Every first-party name of `kind`, with the distribution that registers it."""
    return {
        name: distribution
        for (k, name), distribution in sorted(_index().items(), key=lambda item: item[0][1])
        if k is kind
    }


def catalog_of(plugins: Iterable[PluginInfo]) -> Catalog:
    """The catalog of what `plugins` (loaded, not broken) registered, as providers.json holds it."""
    catalog: Catalog = {}
    for info in plugins:
        provided_by = catalog.setdefault(info.distribution, {})
        for component in info.components:
            provided_by.setdefault(component.kind.value, []).append(component.name)
    return {
        distribution: {kind: sorted(names) for kind, names in sorted(provided_by.items())}
        for distribution, provided_by in sorted(catalog.items())
    }


def catalog_text(catalog: Catalog) -> str:
    """providers.json's text: one stable layout, so that a drift shows as a small diff."""
    return json.dumps(catalog, indent=1, sort_keys=True) + "\n"
