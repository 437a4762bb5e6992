"""Entry point of joshua-mujoco: registers the `mujoco` backend. Imports nothing heavy."""

from __future__ import annotations

from joshua_core import hookimpl
from joshua_core.plugins import Registrar


@hookimpl
def joshua_register_backends(registry: Registrar) -> None:
    registry.add(
        "mujoco",
        "joshua_mujoco.engine:MuJoCoBackend",
        "MuJoCo 4 on the CPU, one simulation per engine",
        env_kinds=("numpy",),
    )
