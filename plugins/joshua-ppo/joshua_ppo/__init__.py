"""JOSHUA's PPO trainer on MJX (JAX/Flax/Optax). `from joshua_ppo import train_mjx` is the Python entry point.

The package stays light (the plugin entry point imports it): `train_mjx` loads JAX only when first used.
"""

from __future__ import annotations

from typing import Any

__all__ = ["train_mjx"]


def __getattr__(name: str) -> Any:
    if name == "train_mjx":
        from joshua_ppo.api import train_mjx

        return train_mjx
    raise AttributeError(f"module 'joshua_ppo' has no attribute {name!r}")
