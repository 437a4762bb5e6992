"""Entry point of joshua-export: registers `joshua export`. Imports nothing heavy (no onnx, no mujoco)."""

from __future__ import annotations

from joshua_core import hookimpl
from joshua_core.plugins import Registrar


@hookimpl
def joshua_register_commands(registry: Registrar) -> None:
    registry.add(
        "export",
        "joshua_export.command:ExportCommand",
        "write a trained run's policy as policy.onnx with its contract policy.json (joshua export RUN_FOLDER)",
    )
