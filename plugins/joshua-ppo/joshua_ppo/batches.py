"""What one iteration collects and learns from: transitions as stepped, and the two forms minibatches take.

`value_observation` is what a separate value network sees: the observation without the noise the task adds
to the policy's (an asymmetric actor-critic); None when the task adds none or the value network shares the
policy's trunk, and the value network then sees `observation`. `views` is what a pixel policy sees beside the
observation (`joshua_ppo.policy.policy_views`: camera images, kept in their own dtype, so an rgb image costs its
H x W x 3 bytes in the buffer, and commands); None for other policies.
"""

from __future__ import annotations

from typing import NamedTuple

import jax


class Transition(NamedTuple):
    """One step of every environment (time-major when stacked over an unroll)."""

    observation: jax.Array
    value_observation: jax.Array | None
    views: dict[str, dict[str, jax.Array]] | None
    action: jax.Array
    log_prob: jax.Array
    value: jax.Array
    reward: jax.Array
    terminated: jax.Array
    truncated: jax.Array
    final_value: jax.Array


class Sample(NamedTuple):
    """One transition with its advantage and value target, computed when it was collected."""

    observation: jax.Array
    value_observation: jax.Array | None
    views: dict[str, dict[str, jax.Array]] | None
    action: jax.Array
    log_prob: jax.Array
    advantage: jax.Array
    target: jax.Array


class Unroll(NamedTuple):
    """One environment's unroll (batch-major: (T, ...) per field), for advantages recomputed per minibatch.

    final_value stays the collecting network's: it only counts on the rare steps that truncate an episode.
    """

    observation: jax.Array
    value_observation: jax.Array | None
    views: dict[str, dict[str, jax.Array]] | None
    action: jax.Array
    log_prob: jax.Array
    reward: jax.Array
    terminated: jax.Array
    truncated: jax.Array
    final_value: jax.Array
    last_observation: jax.Array | None  # (obs,): after the unroll's last step, to bootstrap from
    last_value_observation: jax.Array | None
