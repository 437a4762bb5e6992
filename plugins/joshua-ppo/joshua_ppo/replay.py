"""The off-policy trainers' replay buffer on the device, and n-step targets drawn from it, as pure functions.

The buffer keeps the last `capacity` steps of every environment, time-major (capacity, envs, ...), written as a
ring: one step of all environments per `add`. A transition's next observation is kept beside it (where the
episode ended, the final observation the environment gave before its reset), so an n-step sample never reads
across an episode's end: its rewards stop there, and it bootstraps from that final observation, or not at all
where the episode terminated (a truncated one still has a future).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp


class Replay(NamedTuple):
    """Steps of every environment; `position` is the slot the next step goes to, `count` how many are filled.

    `critic_observation` (and its next) is what the critics see when it is not the actor's observation: the
    observation without its noise, or the flat state beside a pixel actor; None otherwise. `views` holds what a
    pixel actor sees ({"images": ..., "commands": ...}, each (capacity, envs, ...)); None otherwise. The views
    after a step are read from the next slot: where an episode ended there, they are already its successor's
    (only for a truncated episode's bootstrap action, once per episode; a terminated one is not bootstrapped)."""

    observation: jax.Array  # (capacity, envs, obs)
    critic_observation: jax.Array | None
    views: Any
    action: jax.Array  # (capacity, envs, act)
    reward: jax.Array  # (capacity, envs)
    terminated: jax.Array  # (capacity, envs) bool: the episode ended in a terminal state (no bootstrap)
    ended: jax.Array  # (capacity, envs) bool: the episode ended here (terminated or truncated)
    next_observation: jax.Array  # (capacity, envs, obs)
    next_critic_observation: jax.Array | None
    position: jax.Array  # () int32
    count: jax.Array  # type: ignore[assignment]  # () int32; a field that shadows tuple.count, which is unused


class Step(NamedTuple):
    """One step of every environment, as `add` takes it (the Replay's fields without their capacity axis)."""

    observation: jax.Array
    critic_observation: jax.Array | None
    views: Any
    action: jax.Array
    reward: jax.Array
    terminated: jax.Array
    ended: jax.Array
    next_observation: jax.Array
    next_critic_observation: jax.Array | None


class Sample(NamedTuple):
    """A minibatch of n-step transitions: from (observation, action), `reward` is the discounted sum of up to n
    rewards, `discount` gamma^m (0 where the episode terminated within them) and `next_*` what to bootstrap from.
    `next_views` are the views of the step after the sampled one (what the actor sees when it picks the target
    action; beside a pixel actor, only the critics read the bootstrap observation)."""

    observation: jax.Array
    critic_observation: jax.Array | None
    views: Any
    action: jax.Array
    reward: jax.Array
    discount: jax.Array
    next_observation: jax.Array
    next_critic_observation: jax.Array | None
    next_views: Any


def empty_replay(step: Step, capacity: int) -> Replay:
    """A buffer of `capacity` steps shaped like `step` (one step of every environment), holding nothing yet."""
    zeros = jax.tree.map(lambda leaf: jnp.zeros((capacity, *leaf.shape), leaf.dtype), step)
    return Replay(**zeros._asdict(), position=jnp.zeros((), jnp.int32), count=jnp.zeros((), jnp.int32))


def add(replay: Replay, step: Step) -> Replay:
    """The buffer with `step` written at its position (over the oldest step once it is full)."""
    capacity = replay.reward.shape[0]
    written = jax.tree.map(
        lambda stored, new: stored.at[replay.position].set(new), Step._make(replay[: len(Step._fields)]), step
    )
    return Replay(
        **written._asdict(),
        position=(replay.position + 1) % capacity,
        count=jnp.minimum(replay.count + 1, capacity),
    )


def sample(replay: Replay, key: jax.Array, size: int, n_step: int, gamma: float) -> Sample:
    """`size` n-step transitions drawn uniformly (environment and start step) from the filled slots that have
    `n_step` steps and one more after them in the buffer; the buffer must hold at least `n_step` + 1 steps."""
    capacity, envs = replay.reward.shape
    time_key, env_key = jax.random.split(key)
    oldest = (replay.position - replay.count) % capacity
    # a start whose n steps and the slot after them are written: the views after the last step are read
    offset = jax.random.randint(time_key, (size,), 0, jnp.maximum(replay.count - n_step, 1))
    start = (oldest + offset) % capacity
    env = jax.random.randint(env_key, (size,), 0, envs)
    slots = (start[:, None] + jnp.arange(n_step)[None, :]) % capacity  # (size, n)
    rewards = replay.reward[slots, env[:, None]]
    ended = replay.ended[slots, env[:, None]]
    terminated = replay.terminated[slots, env[:, None]]
    reward, discount, last = n_step_return(rewards, ended, terminated, gamma)
    last_slot = slots[jnp.arange(size), last]

    def at(tree: Any, slot: jax.Array) -> Any:
        return jax.tree.map(lambda leaf: leaf[slot, env], tree)

    return Sample(
        observation=at(replay.observation, start),
        critic_observation=at(replay.critic_observation, start),
        views=at(replay.views, start),
        action=at(replay.action, start),
        reward=reward,
        discount=discount,
        next_observation=at(replay.next_observation, last_slot),
        next_critic_observation=at(replay.next_critic_observation, last_slot),
        next_views=at(replay.views, (last_slot + 1) % capacity),
    )


def n_step_return(
    rewards: jax.Array, ended: jax.Array, terminated: jax.Array, gamma: float
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """For rows of n consecutive steps (batch, n) of one environment: the discounted sum of rewards up to and with
    the first step that ends its episode, the discount of the bootstrap after it (gamma^(m + 1), 0 where that step
    terminated) and m, the index of the step whose next observation is bootstrapped from."""
    n = rewards.shape[1]
    ends = ended[:, :-1]
    alive = jnp.concatenate([jnp.ones_like(rewards[:, :1]), jnp.cumprod(1.0 - ends.astype(rewards.dtype), axis=1)], 1)
    powers = gamma ** jnp.arange(n, dtype=rewards.dtype)
    total = jnp.sum(rewards * alive * powers, axis=1)
    last = jnp.where(ended.any(axis=1), jnp.argmax(ended, axis=1), n - 1)
    rows = jnp.arange(rewards.shape[0])
    discount = gamma ** (last + 1).astype(rewards.dtype) * (1.0 - terminated[rows, last].astype(rewards.dtype))
    return total, discount, last
