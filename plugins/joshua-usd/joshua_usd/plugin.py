"""Entry point of joshua-usd: registers the USD model reader, the `usd` backend and `joshua usd`. Imports nothing heavy."""

from __future__ import annotations

from joshua_core import hookimpl
from joshua_core.plugins import Registrar

USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")


@hookimpl
def joshua_register_readers(registry: Registrar) -> None:
    for suffix in USD_SUFFIXES:
        registry.add(suffix, "joshua_usd.reader:UsdReader", "OpenUSD stage with UsdPhysics articulations")


@hookimpl
def joshua_register_commands(registry: Registrar) -> None:
    registry.add("usd", "joshua_usd.cli:UsdCommand", "inspect a USD robot, or export an MJCF model to USD for Isaac")
