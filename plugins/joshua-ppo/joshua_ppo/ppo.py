"""PPO in JAX/Flax/Optax on a functional batched environment (`joshua_mjx.env.MjxEnv`).

One training iteration (collect `unrolls_per_iteration` unrolls of `num_steps` steps in every
environment, update the observation normaliser, compute GAE, then `num_epochs` passes of
minibatch gradient steps; or, with `recompute_advantages`, GAE per minibatch of whole unrolls with
the current value network) is a single compiled function: no Python runs per environment step.
It runs under `jax.shard_map` over the environment's device mesh: each device steps its slice of
the environments and learns from its slice of every minibatch, and the gradients, normaliser
statistics and logged metrics are averaged across devices, so N GPUs act as one N times larger.

`train_ppo` is the whole algorithm: settings in four groups, a seed, and callbacks for progress
and checkpoints. The trainer plugin (`joshua_ppo.trainer`) adds configs, run folders and monitoring.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax
from jax.sharding import PartitionSpec

from joshua_core.errors import ConfigError, JoshuaError
from joshua_mjx.env import ENV_AXIS, EnvState, MjxEnv
from joshua_ppo.networks import (
    ActorCritic,
    SeparateActorCritic,
    gaussian_entropy,
    gaussian_log_prob,
    squashed_entropy,
)

OBSERVATION_CLIP = 10.0  # normalised observations are clipped to +-this
LEARNING_RATE_BOUNDS = (1e-5, 1e-2)  # of the adaptive learning rate
ADVANTAGE_ESTIMATORS = ("gae", "lambda_return")  # ReturnSettings.advantage


@dataclass(frozen=True)
class RolloutSettings:
    """How much experience one iteration collects: num_envs x num_steps x unrolls_per_iteration transitions."""

    num_envs: int = 2048
    num_steps: int = 10  # unroll length: steps per environment between bootstraps
    unrolls_per_iteration: int = 1


@dataclass(frozen=True)
class OptimizationSettings:
    """The PPO update."""

    num_epochs: int = 4
    minibatch_size: int = 256  # transitions per gradient step (all devices together)
    learning_rate: float = 3e-4
    clip_epsilon: float = 0.2
    entropy_coef: float = 0.0
    value_coef: float = 0.5
    max_grad_norm: float | None = 1.0
    # > 0: adapt the learning rate on every gradient step to keep the policy's KL divergence from the
    # collecting policy near this (see adapt_learning_rate); 0: a constant learning rate
    desired_kl: float = 0.0
    # > 0: the learning rate falls linearly from learning_rate to 0 over this many environment steps
    # (counted from the run's start, so across resumes); 0: no annealing
    anneal_steps: int = 0


@dataclass(frozen=True)
class ReturnSettings:
    """Returns and advantages."""

    gamma: float = 0.99
    gae_lambda: float = 0.95
    reward_scaling: float = 1.0  # rewards are multiplied by this for learning; reported returns are unscaled
    # GAE and value targets recomputed on every minibatch with the current value network (as Brax does),
    # rather than once per iteration with the network that collected the data
    recompute_advantages: bool = False
    # "gae": sum over k of (gamma lambda)^k TD errors (Schulman et al.); "lambda_return": the TD error
    # towards the next step's lambda-return, r + gamma G_{t+1} - V(s_t) (Brax's PPO), which weighs the
    # next step's advantage by gamma rather than gamma lambda
    advantage: str = "gae"


@dataclass(frozen=True)
class NetworkSettings:
    """The actor-critic network, its input and its output."""

    hidden_sizes: tuple[int, ...] = (256, 256)  # the shared trunk; the policy's layers when value_hidden_sizes is set
    value_hidden_sizes: tuple[int, ...] = ()  # set: a separate value network of these layers
    normalize_observations: bool = True
    squash_actions: bool = False  # tanh of the Gaussian sample goes to the env, rather than the sample clipped
    activation: str = "relu"  # of the hidden layers: a name in joshua_ppo.networks.ACTIVATIONS
    state_dependent_std: bool = False  # the policy network outputs the std too, rather than one learned vector


class RunningStatistics(NamedTuple):
    """Running mean and variance of observations (Chan et al.'s parallel update)."""

    count: jax.Array
    mean: jax.Array
    variance: jax.Array


class TrainingState(NamedTuple):
    """Everything one iteration changes: parameters, optimiser, normaliser, environments, random key."""

    params: Any
    opt_state: Any
    normalizer: RunningStatistics
    env_state: EnvState
    key: jax.Array


class Progress(NamedTuple):
    """Counters that live outside the compiled iteration (and in checkpoints)."""

    iteration: int
    env_steps: int


@dataclass
class IterationReport:
    """What one iteration did: counters, timing, and its metrics as Python floats.

    metrics: `mean_return` and `mean_length` of the episodes that ended in this iteration
    (`episodes` of them; NaN when none), `reward/<term>` episode sums, `metrics/<name>` on the
    episodes' last steps, and the losses (`loss`, `policy_loss`, `value_loss`, `entropy`,
    `approx_kl`, `clip_fraction`, `action_std`, the policy's mean standard deviation, and
    `learning_rate`, the mean over the iteration's gradient steps).
    """

    iteration: int
    env_steps: int
    total_steps: int
    iteration_seconds: float
    steps_per_second: float
    wall_seconds: float  # since train_ppo was called
    compile_seconds: float  # before the first iteration: environments reset and the iteration compiled, at once
    metrics: dict[str, float] = field(default_factory=dict)


class TrainingDiverged(JoshuaError):
    """A loss or parameter became NaN or infinite; training stopped before writing anything from that state."""


ProgressCallback = Callable[[IterationReport, TrainingState], None]
CheckpointCallback = Callable[[TrainingState, Progress, IterationReport | None], None]


def check_settings(
    rollout: RolloutSettings, optimization: OptimizationSettings, devices: int, whole_unrolls: bool = False
) -> int:
    """Validate the batch arithmetic and the learning-rate options; returns the number of minibatches per epoch.

    whole_unrolls: minibatches are made of whole unrolls (for recomputing advantages), not single steps.
    """
    for name, value in (
        ("num_envs", rollout.num_envs),
        ("num_steps", rollout.num_steps),
        ("unrolls_per_iteration", rollout.unrolls_per_iteration),
        ("num_epochs", optimization.num_epochs),
        ("minibatch_size", optimization.minibatch_size),
    ):
        if value < 1:
            raise ConfigError(f"PPO setting {name} must be at least 1, got {value}")
    batch = rollout.num_envs * rollout.num_steps * rollout.unrolls_per_iteration
    if batch % optimization.minibatch_size:
        raise ConfigError(
            f"minibatch_size {optimization.minibatch_size} must divide the iteration's "
            f"num_envs x num_steps x unrolls_per_iteration = {batch} transitions"
        )
    if optimization.minibatch_size % devices:
        raise ConfigError(f"minibatch_size {optimization.minibatch_size} must be a multiple of the {devices} devices")
    if optimization.desired_kl > 0 and optimization.anneal_steps > 0:
        raise ConfigError(
            "desired_kl and an annealed learning rate cannot be combined (both set the learning rate): "
            "drop ppo.desired_kl or ppo.anneal_learning_rate (anneal_steps)"
        )
    if whole_unrolls and optimization.minibatch_size % (devices * rollout.num_steps):
        raise ConfigError(
            f"with recompute_advantages, minibatch_size {optimization.minibatch_size} must be a multiple of "
            f"num_steps x devices = {rollout.num_steps * devices} (minibatches are made of whole unrolls)"
        )
    return batch // optimization.minibatch_size


def make_network(env: MjxEnv, network: NetworkSettings) -> ActorCritic | SeparateActorCritic:
    shape = {"activation": network.activation, "state_dependent_std": network.state_dependent_std}
    if network.value_hidden_sizes:
        return SeparateActorCritic(
            env.action_size, tuple(network.hidden_sizes), tuple(network.value_hidden_sizes), **shape
        )
    return ActorCritic(action_dim=env.action_size, hidden_sizes=tuple(network.hidden_sizes), **shape)


def env_actions(sample: jax.Array, network: NetworkSettings) -> jax.Array:
    """What the environment gets for a policy sample (or mean): squashed by tanh, or as is (the env clips)."""
    return jnp.tanh(sample) if network.squash_actions else sample


def make_optimizer(optimization: OptimizationSettings) -> optax.GradientTransformation:
    """Adam after optional global-norm clipping, with the learning rate in its state (the adaptive schedule sets it)."""

    def chain(learning_rate: float) -> optax.GradientTransformation:
        adam = optax.adam(learning_rate)
        if optimization.max_grad_norm is None:
            return adam
        return optax.chain(optax.clip_by_global_norm(optimization.max_grad_norm), adam)

    return optax.inject_hyperparams(chain)(learning_rate=optimization.learning_rate)


def adapt_learning_rate(learning_rate: jax.Array, kl: jax.Array, desired_kl: float) -> jax.Array:
    """The adaptive schedule of rsl_rl (Isaac Lab's PPO): divide the learning rate by 1.5 when the KL
    divergence from the collecting policy exceeds twice the desired one, multiply it by 1.5 when it is
    below half, within LEARNING_RATE_BOUNDS. Steps stay small where the policy is sharp (a small std makes
    every change of the mean a large change of the distribution) and grow where it barely moves."""
    lower, upper = LEARNING_RATE_BOUNDS
    # not on a KL of 0: the first step after collecting, before the policy has moved
    faster = jnp.where((kl > 0) & (kl < desired_kl / 2.0), jnp.minimum(learning_rate * 1.5, upper), learning_rate)
    return jnp.where(kl > desired_kl * 2.0, jnp.maximum(learning_rate / 1.5, lower), faster)


def normalize(stats: RunningStatistics, observation: jax.Array, enabled: bool) -> jax.Array:
    """Observations scaled by the running statistics and clipped (unchanged when normalisation is off)."""
    if not enabled:
        return observation
    scaled = (observation - stats.mean) / jnp.sqrt(stats.variance + 1e-8)
    return jnp.clip(scaled, -OBSERVATION_CLIP, OBSERVATION_CLIP)


def init_state(
    env: MjxEnv, *, seed: int, network: NetworkSettings, optimization: OptimizationSettings
) -> TrainingState:
    """Fresh parameters, optimiser and normaliser, and freshly reset environments."""
    key = jax.random.PRNGKey(seed)
    key, init_key, reset_key = jax.random.split(key, 3)
    params = make_network(env, network).init(init_key, jnp.zeros((1, env.observation_size)))["params"]
    size = env.observation_size
    normalizer = RunningStatistics(jnp.zeros((), jnp.float32), jnp.zeros(size), jnp.ones(size))
    state = TrainingState(params, make_optimizer(optimization).init(params), normalizer, env.reset(reset_key), key)
    return jax.device_put(state, _state_shardings(env))


def _state_shardings(env: MjxEnv) -> TrainingState:
    """Where a training state lives (a prefix of its tree): environments split over devices, the rest replicated."""
    return TrainingState(env.replicated, env.replicated, env.replicated, env.sharding, env.replicated)


def _abstract_state(env: MjxEnv, *, network: NetworkSettings, optimization: OptimizationSettings) -> TrainingState:
    """Shapes, dtypes and shardings of `init_state`'s result, computing nothing: enough to compile the iteration."""
    shapes = jax.eval_shape(lambda: init_state(env, seed=0, network=network, optimization=optimization))

    def placed(sharding: jax.sharding.Sharding, subtree: Any) -> Any:
        return jax.tree.map(lambda leaf: jax.ShapeDtypeStruct(leaf.shape, leaf.dtype, sharding=sharding), subtree)

    return jax.tree.map(placed, _state_shardings(env), shapes)


class _Transition(NamedTuple):
    observation: jax.Array
    action: jax.Array
    log_prob: jax.Array
    value: jax.Array
    reward: jax.Array
    terminated: jax.Array
    truncated: jax.Array
    final_value: jax.Array


class _Sample(NamedTuple):
    """One transition with its advantage and value target, computed when it was collected."""

    observation: jax.Array
    action: jax.Array
    log_prob: jax.Array
    advantage: jax.Array
    target: jax.Array


class _Unroll(NamedTuple):
    """One environment's unroll (batch-major: (T, ...) per field), for advantages recomputed per minibatch.

    final_value stays the collecting network's: it only counts on the rare steps that truncate an episode.
    """

    observation: jax.Array
    action: jax.Array
    log_prob: jax.Array
    reward: jax.Array
    terminated: jax.Array
    truncated: jax.Array
    final_value: jax.Array
    last_observation: jax.Array  # (obs,): after the unroll's last step, to bootstrap from


def make_iteration(
    env: MjxEnv,
    *,
    rollout: RolloutSettings,
    optimization: OptimizationSettings,
    returns: ReturnSettings,
    network: NetworkSettings,
) -> Callable[[TrainingState], tuple[TrainingState, dict[str, jax.Array]]]:
    """The compiled training iteration: state -> (next state, metrics as scalars)."""
    if returns.advantage not in ADVANTAGE_ESTIMATORS:
        raise ConfigError(f"advantage '{returns.advantage}' is not one of: {', '.join(ADVANTAGE_ESTIMATORS)}")
    devices = env.mesh.size
    recompute = returns.recompute_advantages
    num_minibatches = check_settings(rollout, optimization, devices, whole_unrolls=recompute)
    local_minibatch = optimization.minibatch_size // devices // (rollout.num_steps if recompute else 1)
    env_steps_per_gradient_step = optimization.minibatch_size / optimization.num_epochs
    net = make_network(env, network)
    optimizer = make_optimizer(optimization)
    normalizing = network.normalize_observations
    empty_leaves = _EmptyLeaves.of(env)
    reward_terms = [term.name for term in env.task.reward_terms]
    metric_terms = [term.name for term in env.task.metric_terms]

    def apply(params: Any, stats: RunningStatistics, observation: jax.Array) -> tuple[jax.Array, ...]:
        return net.apply({"params": params}, normalize(stats, observation, normalizing))

    def env_step(
        carry: tuple[EnvState, Any, RunningStatistics], key: jax.Array
    ) -> tuple[tuple[EnvState, Any, RunningStatistics], tuple[_Transition, dict[str, jax.Array]]]:
        env_state, params, stats = carry
        mean, log_std, value = apply(params, stats, env_state.observation)
        action = mean + jnp.exp(log_std) * jax.random.normal(key, mean.shape)
        next_state = env.step(env_state, env_actions(action, network))
        _, _, final_value = apply(params, stats, next_state.final_observation)
        transition = _Transition(
            observation=env_state.observation,
            action=action,
            log_prob=gaussian_log_prob(action, mean, log_std),
            value=value,
            reward=next_state.reward * returns.reward_scaling,
            terminated=next_state.terminated,
            truncated=next_state.truncated,
            final_value=final_value,
        )
        return (next_state, params, stats), (transition, _episode_sums(next_state, reward_terms, metric_terms))

    def unroll(
        carry: tuple[EnvState, Any, RunningStatistics], key: jax.Array
    ) -> tuple[tuple[EnvState, Any, RunningStatistics], tuple[_Sample | _Unroll, dict[str, jax.Array]]]:
        carry, (steps, sums) = jax.lax.scan(env_step, carry, jax.random.split(key, rollout.num_steps))
        env_state, params, stats = carry
        sums = jax.tree.map(lambda x: x.sum(axis=0), sums)
        if recompute:
            fields = {name: getattr(steps, name) for name in _Unroll._fields[:-1]}
            batch_major = jax.tree.map(lambda x: jnp.swapaxes(x, 0, 1), fields)
            return carry, (_Unroll(**batch_major, last_observation=env_state.observation), sums)
        _, _, last_value = apply(params, stats, env_state.observation)
        advantage, target = estimate_advantages(returns, steps.value, last_value, steps)
        return carry, (_Sample(steps.observation, steps.action, steps.log_prob, advantage, target), sums)

    def entropy_of(mean: jax.Array, log_std: jax.Array, key: jax.Array) -> jax.Array:
        """Mean entropy of the action distribution (of the squashed actions when the policy squashes)."""
        if network.squash_actions:
            return squashed_entropy(mean, log_std, jax.random.normal(key, mean.shape)).mean()
        return gaussian_entropy(log_std).mean()  # log_std (A,) or (N, A): the mean is the same

    def current_advantages(
        params: Any, stats: RunningStatistics, batch: _Unroll, value: jax.Array
    ) -> tuple[jax.Array, jax.Array]:
        """A minibatch of unrolls' advantages and targets (batch-major) from the current value network."""
        _, _, last_value = apply(params, stats, batch.last_observation)
        time_major = jax.tree.map(lambda x: jnp.swapaxes(x, 0, 1), batch._replace(last_observation=None))
        advantage, target = estimate_advantages(returns, value.T, last_value, time_major)
        return jax.lax.stop_gradient((advantage.T, target.T))

    def loss_fn(
        params: Any, stats: RunningStatistics, batch: _Sample | _Unroll, key: jax.Array
    ) -> tuple[jax.Array, dict[str, jax.Array]]:
        mean, log_std, value = apply(params, stats, batch.observation)
        if recompute:
            advantage, target = current_advantages(params, stats, batch, value)
        else:
            advantage, target = batch.advantage, batch.target
        log_prob = gaussian_log_prob(batch.action, mean, log_std)
        log_ratio = log_prob - batch.log_prob
        ratio = jnp.exp(log_ratio)
        advantage = (advantage - advantage.mean()) / (advantage.std() + 1e-8)
        clipped = jnp.clip(ratio, 1.0 - optimization.clip_epsilon, 1.0 + optimization.clip_epsilon)
        policy_loss = -jnp.minimum(ratio * advantage, clipped * advantage).mean()
        value_loss = 0.5 * jnp.square(value - target).mean()
        entropy = entropy_of(mean, log_std, key)
        loss = policy_loss + optimization.value_coef * value_loss - optimization.entropy_coef * entropy
        return loss, {
            "loss": loss,
            "policy_loss": policy_loss,
            "value_loss": value_loss,
            "entropy": entropy,
            "action_std": jnp.exp(log_std).mean(),
            "approx_kl": ((ratio - 1.0) - log_ratio).mean(),
            "clip_fraction": (jnp.abs(ratio - 1.0) > optimization.clip_epsilon).mean(),
        }

    def gradient_step(
        carry: tuple[Any, Any, RunningStatistics], batch_and_key: tuple[_Sample, jax.Array]
    ) -> tuple[tuple[Any, Any, RunningStatistics], dict[str, jax.Array]]:
        params, opt_state, stats = carry
        grads, losses = jax.grad(loss_fn, has_aux=True)(params, stats, *batch_and_key)
        grads = jax.lax.pmean(grads, ENV_AXIS)
        if optimization.desired_kl > 0:  # the KL before this step, as every device sees it
            kl = jax.lax.pmean(losses["approx_kl"], ENV_AXIS)
            learning_rate = adapt_learning_rate(opt_state.hyperparams["learning_rate"], kl, optimization.desired_kl)
            opt_state = opt_state._replace(hyperparams={**opt_state.hyperparams, "learning_rate": learning_rate})
        if optimization.anneal_steps > 0:  # the optimiser's step count, in environment steps
            progress = opt_state.count * env_steps_per_gradient_step / optimization.anneal_steps
            learning_rate = optimization.learning_rate * jnp.maximum(1.0 - progress, 0.0)
            opt_state = opt_state._replace(hyperparams={**opt_state.hyperparams, "learning_rate": learning_rate})
        updates, opt_state = optimizer.update(grads, opt_state, params)
        losses["learning_rate"] = opt_state.hyperparams["learning_rate"]
        return (optax.apply_updates(params, updates), opt_state, stats), losses

    def epoch(
        carry: tuple[Any, Any, RunningStatistics], key: jax.Array, samples: _Sample | _Unroll
    ) -> tuple[tuple[Any, Any, RunningStatistics], dict[str, jax.Array]]:
        order_key, entropy_key = jax.random.split(key)
        order = jax.random.permutation(order_key, samples.observation.shape[0])
        minibatches = jax.tree.map(lambda x: x[order].reshape(num_minibatches, local_minibatch, *x.shape[1:]), samples)
        return jax.lax.scan(gradient_step, carry, (minibatches, jax.random.split(entropy_key, num_minibatches)))

    def local_iteration(
        params: Any, opt_state: Any, stats: RunningStatistics, filled: list[jax.Array], key: jax.Array
    ) -> tuple[Any, Any, RunningStatistics, list[jax.Array], dict[str, jax.Array]]:
        env_state = empty_leaves.rebuild(filled, devices)
        key = jax.random.fold_in(key, jax.lax.axis_index(ENV_AXIS))
        rollout_key, epoch_key = jax.random.split(key)
        (env_state, _, _), (samples, sums) = jax.lax.scan(
            unroll, (env_state, params, stats), jax.random.split(rollout_key, rollout.unrolls_per_iteration)
        )
        # steps (unrolls * steps * envs, ...) or, to recompute advantages, unrolls (unrolls * envs, steps, ...)
        samples = jax.tree.map(lambda x: x.reshape(-1, *x.shape[2 if recompute else 3 :]), samples)
        if normalizing:
            stats = _update_statistics(stats, samples.observation.reshape(-1, env.observation_size))
        (params, opt_state, _), losses = jax.lax.scan(
            lambda carry, key: epoch(carry, key, samples),
            (params, opt_state, stats),
            jax.random.split(epoch_key, optimization.num_epochs),
        )
        metrics = _episode_metrics(jax.tree.map(lambda x: jax.lax.psum(x.sum(), ENV_AXIS), sums))
        metrics |= {name: jax.lax.pmean(value.mean(), ENV_AXIS) for name, value in losses.items()}
        leaves = jax.tree.leaves(params)
        metrics["params_finite"] = jnp.all(jnp.stack([jnp.isfinite(leaf).all() for leaf in leaves]))
        return params, opt_state, stats, _EmptyLeaves.filled(env_state), metrics

    sharded = jax.shard_map(
        local_iteration,
        mesh=env.mesh,
        in_specs=(PartitionSpec(), PartitionSpec(), PartitionSpec(), PartitionSpec(ENV_AXIS), PartitionSpec()),
        out_specs=(PartitionSpec(), PartitionSpec(), PartitionSpec(), PartitionSpec(ENV_AXIS), PartitionSpec()),
        check_vma=False,
    )

    def iteration(state: TrainingState) -> tuple[TrainingState, dict[str, jax.Array]]:
        key, iteration_key = jax.random.split(state.key)
        params, opt_state, stats, filled, metrics = sharded(
            state.params, state.opt_state, state.normalizer, _EmptyLeaves.filled(state.env_state), iteration_key
        )
        return TrainingState(params, opt_state, stats, empty_leaves.rebuild(filled), key), metrics

    # explicit output shardings: XLA would otherwise replicate the empty per-env arrays (act, plugin_state)
    # and the next call would no longer match the compiled input shardings
    return jax.jit(iteration, donate_argnums=0, out_shardings=(_state_shardings(env), env.replicated))


def estimate_advantages(
    returns: ReturnSettings, value: jax.Array, last_value: jax.Array, steps: _Transition | _Unroll
) -> tuple[jax.Array, jax.Array]:
    """Advantages and value targets (lambda-returns) over unrolls, time-major: value (T, N) estimated before
    each step, last_value (N,) after the last; the trace is cut where an episode ended, a terminated
    episode bootstraps from zero and a truncated one from the value of its final observation."""
    next_values = jnp.concatenate([value[1:], last_value[None]], axis=0)
    bootstrap = jnp.where(steps.truncated, steps.final_value, jnp.where(steps.terminated, 0.0, next_values))
    deltas = steps.reward + returns.gamma * bootstrap - value
    continues = 1.0 - (steps.terminated | steps.truncated).astype(jnp.float32)

    def backward(carry: jax.Array, step: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
        delta, cont = step
        advantage = delta + returns.gamma * returns.gae_lambda * cont * carry
        return advantage, advantage

    # unrolled: a few steps of a few elementwise ops, which a loop would launch one kernel at a time
    # (on every minibatch, with recompute_advantages)
    _, advantage = jax.lax.scan(
        backward, jnp.zeros_like(last_value), (deltas, continues), reverse=True, unroll=min(value.shape[0], 16)
    )
    target = advantage + value
    if returns.advantage == "lambda_return":  # delta_t + gamma (G_{t+1} - V(s_{t+1})) within the episode
        next_advantage = jnp.concatenate([advantage[1:], jnp.zeros_like(last_value)[None]], axis=0)
        advantage = deltas + returns.gamma * continues * next_advantage
    return advantage, target


class _EmptyLeaves(NamedTuple):
    """Where an environment state has zero-size arrays (MJX's buffers for what a model lacks: actuator
    activations, tendons, mocap bodies...). They stay out of `jax.shard_map`, as XLA's GPU compiler
    (jaxlib 0.11, Shardy) crashes on a manual computation with empty per-device inputs; holding no
    values, they are made anew on the other side."""

    treedef: Any
    shapes: list[jax.ShapeDtypeStruct | None]  # of each empty leaf; None where a leaf holds values

    @staticmethod
    def of(env: MjxEnv) -> _EmptyLeaves:
        leaves, treedef = jax.tree.flatten(jax.eval_shape(env.reset, jax.random.PRNGKey(0)))
        return _EmptyLeaves(treedef, [leaf if math.prod(leaf.shape) == 0 else None for leaf in leaves])

    @staticmethod
    def filled(state: EnvState) -> list[jax.Array]:
        """The state's leaves that hold values, in order."""
        return [leaf for leaf in jax.tree.leaves(state) if leaf.size]

    def rebuild(self, filled: list[jax.Array], devices: int = 1) -> EnvState:
        """The state from its filled leaves (inside the shard_map: one of `devices` slices of the environments)."""
        remaining = iter(filled)
        leaves = [
            next(remaining) if empty is None else jnp.zeros((empty.shape[0] // devices, *empty.shape[1:]), empty.dtype)
            for empty in self.shapes
        ]
        return jax.tree.unflatten(self.treedef, leaves)


def _episode_sums(state: EnvState, reward_terms: list[str], metric_terms: list[str]) -> dict[str, jax.Array]:
    """Per-environment sums of the statistics of the episodes that ended on this step."""
    episode = state.episode
    done = episode.done.astype(jnp.float32)
    sums = {"episodes": done, "return": episode.return_ * done, "length": episode.length * done}
    sums |= {f"reward/{name}": episode.reward_terms[name] * done for name in reward_terms}
    sums |= {f"metrics/{name}": episode.metrics[name] * done for name in metric_terms}
    return sums


def _episode_metrics(sums: dict[str, jax.Array]) -> dict[str, jax.Array]:
    """Means over the ended episodes (NaN when none ended)."""
    count = sums.pop("episodes")
    means = {name: value / count for name, value in sums.items()}
    means["mean_return"], means["mean_length"] = means.pop("return"), means.pop("length")
    return {"episodes": count, **means}


def _update_statistics(stats: RunningStatistics, observations: jax.Array) -> RunningStatistics:
    """Merge this iteration's observations (from every device) into the running statistics."""
    batch_count = jax.lax.psum(jnp.asarray(observations.shape[0], jnp.float32), ENV_AXIS)
    batch_mean = jax.lax.psum(observations.sum(axis=0), ENV_AXIS) / batch_count
    batch_variance = jax.lax.psum(jnp.square(observations - batch_mean).sum(axis=0), ENV_AXIS) / batch_count
    total = stats.count + batch_count
    delta = batch_mean - stats.mean
    mean = stats.mean + delta * batch_count / total
    m2 = (
        stats.variance * stats.count
        + batch_variance * batch_count
        + jnp.square(delta) * stats.count * batch_count / total
    )
    return RunningStatistics(total, mean, m2 / total)


def train_ppo(
    env: MjxEnv,
    *,
    rollout: RolloutSettings,
    optimization: OptimizationSettings,
    returns: ReturnSettings,
    network: NetworkSettings,
    total_timesteps: int,
    seed: int = 0,
    checkpoint_interval: int = 0,
    resume: tuple[TrainingState, Progress] | None = None,
    on_progress: ProgressCallback | None = None,
    on_checkpoint: CheckpointCallback | None = None,
) -> tuple[TrainingState, Progress]:
    """Train until `total_timesteps` environment steps (rounded up to whole iterations).

    `on_progress` gets a report after every iteration; `on_checkpoint` gets the state every
    `checkpoint_interval` environment steps (0: never), before the first iteration of a new run
    (the untrained policy) and at the end. `resume` continues from a saved state and its counters.
    Raises TrainingDiverged, without calling `on_checkpoint`, when a loss or parameter stops being finite.
    """
    if resume is not None and resume[0].env_state.observation.shape[0] != env.num_envs:
        raise ConfigError(
            f"the saved state has {resume[0].env_state.observation.shape[0]} environments, not {env.num_envs}"
        )
    started = time.perf_counter()
    iteration = make_iteration(env, rollout=rollout, optimization=optimization, returns=returns, network=network)
    abstract = _abstract_state(env, network=network, optimization=optimization)
    # the iteration compiles while the environments reset (which compiles mjx.forward): both take seconds
    # of XLA compilation, which runs without holding the GIL
    with ThreadPoolExecutor(max_workers=1) as pool:
        compiling = pool.submit(lambda: iteration.lower(abstract).compile())
        state, progress = resume or (
            init_state(env, seed=seed, network=network, optimization=optimization),
            Progress(0, 0),
        )
        compiled = compiling.result()
    compile_seconds = time.perf_counter() - started
    steps_per_iteration = rollout.num_envs * rollout.num_steps * rollout.unrolls_per_iteration
    iterations = max(0, math.ceil((total_timesteps - progress.env_steps) / steps_per_iteration))
    total_steps = progress.env_steps + iterations * steps_per_iteration
    if resume is None and on_checkpoint is not None:
        on_checkpoint(state, progress, None)
    next_checkpoint = progress.env_steps + checkpoint_interval if checkpoint_interval > 0 else None
    report: IterationReport | None = None
    for _ in range(iterations):
        iteration_started = time.perf_counter()
        # every iteration's episodes start from fresh draws of the task's reset terms
        state = state._replace(env_state=env.redraw_starts(state.env_state))
        candidate, metrics = compiled(state)
        values = {name: float(value) for name, value in jax.device_get(metrics).items()}
        finite = values.pop("params_finite") == 1.0
        bad = [name for name in ("loss", "policy_loss", "value_loss") if not math.isfinite(values[name])]
        if bad or not finite:
            what = f"{', '.join(bad)} became {values[bad[0]]}" if bad else "the network parameters became non-finite"
            raise TrainingDiverged(
                f"training diverged in iteration {progress.iteration + 1} ({progress.env_steps} steps done): {what}; "
                "the last checkpoint written before it is kept. Lower training.learning_rate, set "
                "training.ppo.max_grad_norm, or check the task's rewards and observations for huge values"
            )
        state = candidate
        elapsed = time.perf_counter() - iteration_started
        progress = Progress(progress.iteration + 1, progress.env_steps + steps_per_iteration)
        report = IterationReport(
            iteration=progress.iteration,
            env_steps=progress.env_steps,
            total_steps=total_steps,
            iteration_seconds=elapsed,
            steps_per_second=steps_per_iteration / elapsed,
            wall_seconds=time.perf_counter() - started,
            compile_seconds=compile_seconds,
            metrics=values,
        )
        if on_progress is not None:
            on_progress(report, state)
        due = next_checkpoint is not None and progress.env_steps >= next_checkpoint
        if on_checkpoint is not None and (due or progress.env_steps >= total_steps):
            on_checkpoint(state, progress, report)
            while next_checkpoint is not None and next_checkpoint <= progress.env_steps:
                next_checkpoint += checkpoint_interval
    return state, progress


def policy_actions(
    net: ActorCritic | SeparateActorCritic,
    params: Any,
    stats: RunningStatistics,
    observation: jax.Array,
    network: NetworkSettings,
) -> jax.Array:
    """The deterministic policy's actions (the Gaussian's mean, squashed when the policy squashes)."""
    mean, _, _ = net.apply({"params": params}, normalize(stats, observation, network.normalize_observations))
    return env_actions(mean, network)


def as_numpy(tree: Any) -> Any:
    """A pytree's arrays as numpy arrays on the host."""
    return jax.tree.map(np.asarray, jax.device_get(tree))
