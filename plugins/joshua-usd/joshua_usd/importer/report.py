"""What an import noticed: warnings naming prims (printed once by the reader) and errors as one-line ModelErrors."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from joshua_core.errors import ModelError


@dataclass
class ImportReport:
    """Warnings collected while importing `path`, the prim each MuJoCo element came from (for `inspect`), keyed by
    (kind, name) with kind "body", "joint" or "geom", and the authored attributes the import used, as (prim path,
    attribute name): `inspect` lists every other authored physics attribute, so that nothing is dropped silently."""

    path: Path
    warnings: list[str] = field(default_factory=list)
    sources: dict[tuple[str, str], str] = field(default_factory=dict)
    used: set[tuple[str, str]] = field(default_factory=set)

    def warn(self, prim: object, message: str) -> None:
        """Record something approximated or not supported at `prim` (a path), once."""
        text = f"{prim}: {message}"
        if text not in self.warnings:
            self.warnings.append(text)

    def ignore(self, prim: object, attribute: str) -> None:
        """Count an attribute that was read but left out of the model (warned about) as not used."""
        self.used.discard((str(prim), attribute))

    def error(self, prim: object, attribute: str, message: str) -> ModelError:
        """A one-line ModelError naming the file, the prim and the attribute at fault (to be raised)."""
        return ModelError(f"{self.path}: {prim}: {attribute}: {message}")
