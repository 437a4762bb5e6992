"""JOSHUA's MJX backend: JOSHUA tasks on thousands of MuJoCo XLA simulations inside `jax.jit`.

`MjxEnv` (EnvKind.JAX; made by `make_mjx_env`, or by the backend's `create_envs`) and `MjxEngine` are
exported here; this package module stays light because the plugin entry point imports it: jax and
mujoco are imported the first time one of the names below is used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from joshua_mjx.backend import MjxBackend
    from joshua_mjx.engine import MJX_SUFFIX, MjxEngine, mjx_variant
    from joshua_mjx.env import EnvState, MjxEnv, make_mjx_env
    from joshua_mjx.external import ExternalPhysics
    from joshua_mjx.impl import WARP, Physics

__all__ = [
    "MJX_SUFFIX",
    "MjxBackend",
    "MjxEngine",
    "EnvState",
    "ExternalPhysics",
    "MjxEnv",
    "make_mjx_env",
    "mjx_variant",
    "Physics",
    "WARP",
]
_HOME = {
    "EnvState": "env",
    "ExternalPhysics": "external",
    "MjxEnv": "env",
    "make_mjx_env": "env",
    "MjxBackend": "backend",
    "Physics": "impl",
    "WARP": "impl",
}  # else engine.py


def __getattr__(name: str) -> Any:
    if name in __all__:
        import importlib

        module = _HOME.get(name, "engine")
        return getattr(importlib.import_module(f"joshua_mjx.{module}"), name)
    raise AttributeError(f"module 'joshua_mjx' has no attribute '{name}'")
