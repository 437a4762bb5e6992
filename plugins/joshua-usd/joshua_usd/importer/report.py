"""What an import noticed: warnings naming prims (printed once by the reader) and errors as one-line ModelErrors."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from joshua_core.errors import ModelError


@dataclass
class ImportReport:
    """Warnings collected while importing `path`, and the prim each MuJoCo element came from (for `inspect`),
    keyed by (kind, name) with kind "body", "joint" or "geom"."""

    path: Path
    warnings: list[str] = field(default_factory=list)
    sources: dict[tuple[str, str], str] = field(default_factory=dict)

    def warn(self, prim: object, message: str) -> None:
        """Record something approximated or not supported at `prim` (a path), once."""
        text = f"{prim}: {message}"
        if text not in self.warnings:
            self.warnings.append(text)

    def error(self, prim: object, attribute: str, message: str) -> ModelError:
        """A one-line ModelError naming the file, the prim and the attribute at fault (to be raised)."""
        return ModelError(f"{self.path}: {prim}: {attribute}: {message}")
