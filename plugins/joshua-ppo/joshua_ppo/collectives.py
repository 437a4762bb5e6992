"""Sums and means over the devices of the environments' mesh axis that give the same bits however the devices are
split between processes.

`jax.lax.psum` adds the devices' values in an order its collective chooses: on GPUs NCCL's rings and trees differ
between one process of four GPUs and two processes of two, and so do the last bits of the sum. PPO's Adam step
turns those bits into a visible difference for every parameter whose gradient sits near zero (it moves about the
learning rate whichever way the sign tips), so runs that should be the same drift apart over iterations.

Here each device places its value in its own row of a zero array with a row per device, the all-reduce adds the
rows (every row's sum is one value plus zeros: exact in any order) and each device then adds the rows in device
order itself. An all-reduce of D times the data, for networks of PPO's size a small price. (An all-gather would do
the same with no arithmetic, but with one process's collectives in flight it deadlocked the host-side collectives
that stop a multi-process run on a signal, on the CPU: `bench/multiprocess_check.py --smoke`.)
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp


def ordered_sum(tree: Any, axis: str) -> Any:
    """Each leaf summed over the devices of mesh `axis`, in device order."""

    def leaf_sum(leaf: jax.Array) -> jax.Array:
        rows = jnp.zeros((jax.lax.axis_size(axis), *leaf.shape), leaf.dtype)
        return jax.lax.psum(rows.at[jax.lax.axis_index(axis)].set(leaf), axis).sum(axis=0)

    return jax.tree.map(leaf_sum, tree)


def ordered_mean(tree: Any, axis: str) -> Any:
    """Each leaf averaged over the devices of mesh `axis`, in device order."""
    return jax.tree.map(lambda leaf: leaf / jax.lax.axis_size(axis), ordered_sum(tree, axis))
