"""JOSHUA's MuJoCo backend: `MuJoCoEngine`, one MuJoCo simulation behind the seed's API.

The package itself stays light (the `joshua` entry point imports `joshua_mujoco.plugin`);
mujoco is imported the first time `MuJoCoEngine` or `MuJoCoBackend` is used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from joshua_mujoco.engine import MuJoCoBackend, MuJoCoEngine

__all__ = ["MuJoCoBackend", "MuJoCoEngine"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from joshua_mujoco import engine

        return getattr(engine, name)
    raise AttributeError(f"module 'joshua_mujoco' has no attribute '{name}'")
