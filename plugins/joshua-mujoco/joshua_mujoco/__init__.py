"""JOSHUA's MuJoCo backend: `MuJoCoEngine`, one MuJoCo simulation behind the seed's API, and batched
CPU environments of any task (`BatchedVectorEnv`, EnvKind.NUMPY).

The package itself stays light (the `joshua` entry point imports `joshua_mujoco.plugin`);
mujoco is imported the first time one of the names below is used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from joshua_mujoco.engine import MuJoCoBackend, MuJoCoEngine, compile_model
    from joshua_mujoco.vector import BatchedVectorEnv, make_vector_env, vector_env_from_config

# Each exported name and the module that defines it.
_MODULES = {
    "MuJoCoBackend": "engine",
    "MuJoCoEngine": "engine",
    "compile_model": "engine",
    "BatchedVectorEnv": "vector",
    "make_vector_env": "vector",
    "vector_env_from_config": "vector",
}
__all__ = list(_MODULES)


def __getattr__(name: str) -> Any:
    if name in _MODULES:
        import importlib

        return getattr(importlib.import_module(f"joshua_mujoco.{_MODULES[name]}"), name)
    raise AttributeError(f"module 'joshua_mujoco' has no attribute '{name}'")
