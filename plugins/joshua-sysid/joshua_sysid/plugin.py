"""Entry point of joshua-sysid: registers `joshua sysid`. Imports nothing heavy."""

from __future__ import annotations

from joshua_core import hookimpl
from joshua_core.plugins import Registrar


@hookimpl
def joshua_register_commands(registry: Registrar) -> None:
    registry.add(
        "sysid",
        "joshua_sysid.command:SysidCommand",
        "fit kp, damping, armature and friction loss per joint to recordings; write the calibrated model",
    )
