"""Helpers over a batch of environments, each on the leading axis: per-environment random draws, picking one
state or another per environment, and what of an `mjx.Data` a new episode must take (`joshua_mjx.env`)."""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

# What mjx.step reads of a Data (MuJoCo's integration state, mjSTATE_INTEGRATION); it recomputes the rest
STEP_INPUTS = (
    "time",
    "qpos",
    "qvel",
    "act",
    "history",
    "plugin_state",
    "ctrl",
    "qfrc_applied",
    "xfrc_applied",
    "eq_active",
    "mocap_pos",
    "mocap_quat",
    "userdata",
    "qacc_warmstart",
)


class PerEnvRandom:
    """A RandomSource with one key per environment (not one for the batch), so that each device draws
    for its own slice of the environments and an environment's draws do not depend on the batch size."""

    def __init__(self, keys: jax.Array) -> None:
        self.keys = keys

    def _draw(self, shape: tuple[int, ...], sample: Any) -> jax.Array:
        self.keys, subkeys = split_each(self.keys)
        return jax.vmap(lambda key: sample(key, shape[1:]))(subkeys)

    def uniform(self, shape: tuple[int, ...], low: Any = 0.0, high: Any = 1.0) -> jax.Array:
        unit = self._draw(shape, lambda key, s: jax.random.uniform(key, s))
        return low + (jnp.asarray(high) - low) * unit

    def normal(self, shape: tuple[int, ...]) -> jax.Array:
        return self._draw(shape, lambda key, s: jax.random.normal(key, s))


def split_each(keys: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Split every environment's key: (the keys to keep, fresh subkeys to draw from)."""
    pairs = jax.vmap(jax.random.split)(keys)
    return pairs[:, 0], pairs[:, 1]


def where_env(mask: jax.Array, new: Any, old: Any) -> Any:
    """`new` where `mask` (N,) is set, else `old`, leaf by leaf along the leading environment axis."""

    def pick(a: jax.Array, b: jax.Array) -> jax.Array:
        return jnp.where(mask.reshape(mask.shape + (1,) * (jnp.ndim(a) - 1)), a, b)

    return jax.tree.map(pick, new, old)
