"""Entry point of joshua-rk4: registers the `mujoco_rk4` backend, the `RK4_COMPARE` mode and its options.

`joshua` imports this module whenever it discovers plugins: `joshua plugins` and every run. It
imports nothing heavy: it names the backend and mode classes by their "module:attribute" paths, so
mujoco is imported only when a run selects them (`simulation.backend: "mujoco_rk4"`,
`simulation.mode: RK4_COMPARE`). The options target is the extension in the generated
`joshua_rk4.options_pb2`, which imports only protobuf and the core schema, so the CLI can load it
before parsing a config.
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


@hookimpl
def joshua_register_modes(registry: Registrar) -> None:
    registry.add(
        "RK4_COMPARE",
        "joshua_rk4.compare:CompareMode",
        "the model's integrator against RK4 from the same start: their divergence as JSON",
    )


@hookimpl
def joshua_register_options(registry: Registrar) -> None:
    registry.add("rk4_compare", "joshua_rk4.options_pb2:rk4_compare", "RK4_COMPARE: steps, tolerance, report name")
