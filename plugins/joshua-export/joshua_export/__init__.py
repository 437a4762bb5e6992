"""JOSHUA's policy export: `joshua export RUN` writes policy.onnx and its contract policy.json.

The package stays light (the `joshua` entry point imports `joshua_export.plugin`); onnx, onnxruntime and
mujoco load when a name below is first used. Exported for deployers (joshua-mirror's `joshua deploy`):
`load_policy(folder) -> (OnnxPolicy, contract dict)`, `contract_observer(contract, plugins)`, the task's
`Observer` checked against the contract (same compiled robot model, same observation terms), `Observer`,
which builds the observation of one robot state through the task's own terms, and `CONTRACT_FILE`, the name
of the contract in an exported folder.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from joshua_export.contract import CONTRACT_FILE
    from joshua_export.loader import OnnxPolicy, contract_observer, load_policy
    from joshua_export.observer import Observer

__all__ = ["CONTRACT_FILE", "OnnxPolicy", "Observer", "contract_observer", "load_policy"]
_MODULES = {
    "CONTRACT_FILE": "contract",
    "OnnxPolicy": "loader",
    "load_policy": "loader",
    "contract_observer": "loader",
    "Observer": "observer",
}


def __getattr__(name: str) -> Any:
    if name in _MODULES:
        import importlib

        return getattr(importlib.import_module(f"joshua_export.{_MODULES[name]}"), name)
    raise AttributeError(f"module 'joshua_export' has no attribute '{name}'")
