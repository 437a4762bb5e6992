"""The model reader for .usd/.usda/.usdc/.usdz: `MuJoCoEngine(model_path="robot.usd")` and every mode and
trainer load USD stages through it."""

from __future__ import annotations

import sys
from pathlib import Path

import mujoco

from joshua_core.interfaces import ModelReader
from joshua_usd.importer import import_usd

# Warnings already printed by this process: a stage loaded again (one per environment) does not repeat them.
_PRINTED: set[str] = set()


class UsdReader(ModelReader):
    """Imports a UsdPhysics stage; its warnings go to stderr once, as `joshua: warning: ...`."""

    def read(self, path: Path) -> mujoco.MjSpec:
        imported = import_usd(path)
        for warning in imported.report.warnings:
            line = f"joshua: warning: {path}: {warning}"
            if line not in _PRINTED:
                _PRINTED.add(line)
                print(line, file=sys.stderr)
        return imported.spec
