"""Entry point of joshua-mjx: registers the `mjx` backend. Imports nothing heavy (no jax, no mujoco)."""

from __future__ import annotations

from joshua_core import hookimpl
from joshua_core.plugins import Registrar


@hookimpl
def joshua_register_backends(registry: Registrar) -> None:
    registry.add(
        "mjx",
        "joshua_mjx.backend:MjxBackend",
        "MuJoCo XLA (JAX): batched task environments on every GPU, or the CPU",
        env_kinds=("jax",),
    )


@hookimpl
def joshua_register_options(registry: Registrar) -> None:
    registry.add(
        "mjx", "joshua_mjx.options_pb2:mjx", "mjx backend's environments: physics impl (JAX or WARP), capacities"
    )
