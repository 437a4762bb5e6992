"""JOSHUA's MJX backend: JOSHUA tasks on thousands of MuJoCo XLA simulations inside `jax.jit`.

`MjxEnv` (EnvKind.JAX; made by `make_mjx_env`, or by the backend's `create_envs`) and `MjxEngine` are
exported here; this package module stays light because the plugin entry point imports it: jax and
mujoco are imported the first time one of the names below is used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from joshua_mjx.engine import MJX_SUFFIX, MjxBackend, MjxEngine
    from joshua_mjx.env import EnvState, MjxEnv, make_mjx_env

# Each exported name and the module that defines it.
_MODULES = {
    "MJX_SUFFIX": "engine",
    "MjxBackend": "engine",
    "MjxEngine": "engine",
    "EnvState": "env",
    "MjxEnv": "env",
    "make_mjx_env": "env",
}
__all__ = list(_MODULES)


def __getattr__(name: str) -> Any:
    if name in _MODULES:
        import importlib

        return getattr(importlib.import_module(f"joshua_mjx.{_MODULES[name]}"), name)
    raise AttributeError(f"module 'joshua_mjx' has no attribute '{name}'")
