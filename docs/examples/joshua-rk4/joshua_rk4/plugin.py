"""Entry point of joshua-rk4: registers the `mujoco_rk4` backend. Imports nothing heavy.

`joshua` imports this module whenever it discovers plugins: `joshua plugins` and every run.
It names the backend class by its "module:attribute" path, so mujoco is imported only when a
run selects the backend (`simulation.backend: "mujoco_rk4"`).
"""

from __future__ import annotations

from joshua_core import hookimpl
from joshua_core.plugins import Registrar


@hookimpl
def joshua_register_backends(registry: Registrar) -> None:
    registry.add(
        "mujoco_rk4",
        "joshua_rk4.backend:RK4Backend",
        "MuJoCo 4 on the CPU with the RK4 integrator",
    )
