"""The compiled training iteration: collect unrolls, update the normaliser, then minibatch epochs of PPO.

One iteration (collect `unrolls_per_iteration` unrolls of `num_steps` steps in every environment,
update the observation normaliser, compute GAE, then `num_epochs` passes of minibatch gradient steps;
or, with `recompute_advantages`, GAE per minibatch of whole unrolls with the current value network)
is a single compiled function: no Python runs per environment step. It runs under `jax.shard_map`
over the environment's device mesh: each device steps its slice of the environments and learns from
its slice of every minibatch, and the gradients, normaliser statistics and logged metrics are averaged
across devices, so N GPUs act as one N times larger.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import optax
from jax.sharding import PartitionSpec

from joshua_core.tasks import METRIC_PREFIX, REWARD_PREFIX
from joshua_ppo.advantages import estimate_advantages
from joshua_ppo.batches import Sample, Transition, Unroll
from joshua_ppo.collectives import ordered_mean
from joshua_ppo.envs import EnvState, JaxEnv, env_axis
from joshua_ppo.losses import imitation_loss, ppo_loss
from joshua_ppo.networks import gaussian_log_prob
from joshua_ppo.normalizer import RunningStatistics, normalize, update_statistics
from joshua_ppo.optimizer import make_optimizer, scheduled_learning_rate
from joshua_ppo.policy import env_actions, make_network, policy_views
from joshua_ppo.settings import (
    NetworkSettings,
    OptimizationSettings,
    ReturnSettings,
    RolloutSettings,
    check_advantage,
    check_settings,
)
from joshua_ppo.state import TrainingState, state_shardings
from joshua_ppo.teacher import Teacher

# XLA runs the kernels of a loop body as one CUDA graph (a command buffer), by default one after another; here
# only their data dependencies order them, since a gradient step's policy and value passes are two chains of small
# kernels that fill a GPU only together
GPU_COMPILER_OPTIONS = {"xla_gpu_command_buffer_scheduling_mode": "CONCURRENT"}
Carry = tuple[Any, Any, RunningStatistics]  # (environments, params, normaliser) in the rollout's scans
Metrics = dict[str, jax.Array]


class UpdateCarry(NamedTuple):
    """What the update's gradient steps pass on."""

    params: Any
    opt_state: Any
    stats: RunningStatistics  # read, not changed, by the update
    stopped: jax.Array  # a minibatch's KL passed max_kl in this iteration: the later steps are skipped


class _Iteration:
    """The steps of one training iteration on one device's slice (traced inside the shard_map)."""

    def __init__(
        self,
        env: JaxEnv,
        rollout: RolloutSettings,
        optimization: OptimizationSettings,
        returns: ReturnSettings,
        network: NetworkSettings,
        teacher: Teacher | None = None,
    ) -> None:
        check_advantage(returns)
        self.env, self.rollout, self.optimization, self.returns, self.network = (
            env,
            rollout,
            optimization,
            returns,
            network,
        )
        self.teacher = teacher
        self.axis = env_axis(env)
        self.devices = env.mesh.size
        self.recompute = returns.recompute_advantages
        self.num_minibatches = check_settings(
            rollout, optimization, env.num_envs, self.devices, whole_unrolls=self.recompute
        )
        self.local_minibatch = (
            optimization.minibatch_size // self.devices // (rollout.num_steps if self.recompute else 1)
        )
        self.env_steps_per_gradient_step = optimization.minibatch_size / optimization.num_epochs
        # truncated episodes per step whose final values are computed on their own: 1 in 64 environments is
        # 15x what tuned Ant's 1000-step episodes truncate on an average step
        self.final_rows = max(1, env.num_envs // self.devices // 64)
        self.net = make_network(env, network)
        self.optimizer = make_optimizer(optimization)
        self.empty_leaves = EmptyLeaves.of(env)
        self.reward_terms = [term.name for term in env.task.reward_terms]
        self.metric_terms = [term.name for term in env.task.metric_terms]

    def apply(
        self,
        params: Any,
        stats: RunningStatistics,
        observation: jax.Array | None,
        value_observation: jax.Array | None,
        views: dict[str, dict[str, jax.Array]] | None = None,
    ) -> tuple[jax.Array, ...]:
        """(mean, log_std, value); the value of `value_observation` where given (one normaliser for both). A pixel
        policy sees `views` too; without them it gives the value alone (mean and log_std None)."""
        inputs = [
            None if x is None else normalize(stats, x, self.network.normalize_observations)
            for x in (observation, value_observation)
        ]
        # flax types apply's result as `output | (output, variables)`; without `mutable` it is the output
        if self.network.pixels is not None:
            return self.net.apply({"params": params}, *inputs, views)  # type: ignore[return-value]
        return self.net.apply({"params": params}, *(x for x in inputs if x is not None))  # type: ignore[return-value]

    def value_view(self, value_observation: jax.Array | None) -> jax.Array | None:
        """What the value network sees apart from the policy: the environment's observation without noise, for
        a separate value network (a shared trunk sees the policy's observation)."""
        return value_observation if self.network.separate_value_network else None

    def env_step(self, carry: Carry, key: jax.Array) -> tuple[Carry, tuple[Transition, Metrics]]:
        env_state, params, stats = carry
        # outputs never read (the policy on the final observation; with recompute_advantages, the value on the
        # observation) are dropped when JAX traces the iteration: tests/test_iteration_work.py counts the rest
        value_observation = self.value_view(env_state.value_observation)
        views = policy_views(env_state, self.network)
        mean, log_std, value = self.apply(params, stats, env_state.observation, value_observation, views)
        action = mean + jnp.exp(log_std) * jax.random.normal(key, mean.shape)
        next_state = self.env.step(env_state, env_actions(action, self.network))
        final_value = self.final_values(params, stats, next_state)
        transition = Transition(
            observation=env_state.observation,
            value_observation=value_observation,
            views=views,
            action=action,
            log_prob=gaussian_log_prob(action, mean, log_std),
            value=value,
            reward=next_state.reward * self.returns.reward_scaling,
            terminated=next_state.terminated,
            truncated=next_state.truncated,
            final_value=final_value,
        )
        return (next_state, params, stats), (
            transition,
            episode_sums(next_state, self.reward_terms, self.metric_terms),
        )

    def final_values(self, params: Any, stats: RunningStatistics, state: EnvState) -> jax.Array:
        """The value of each environment's final observation where its episode was truncated; elsewhere (0 or
        the value) it is never read. Episodes end by truncation about once per episode_length steps, so the
        value network runs on up to `final_rows` gathered environments, and on all only on a step with more."""
        truncated = state.truncated
        final = (state.final_observation, self.value_view(state.final_value_observation))

        def gathered() -> jax.Array:
            (rows,) = jnp.nonzero(truncated, size=self.final_rows, fill_value=0)  # padded with environment 0
            observation, value_observation = (None if x is None else x[rows] for x in final)
            _, _, values = self.apply(params, stats, observation, value_observation)
            return jnp.zeros(truncated.shape, values.dtype).at[rows].set(jnp.where(truncated[rows], values, 0.0))

        def everywhere() -> jax.Array:
            return self.apply(params, stats, *final)[2]

        return jax.lax.cond(truncated.sum() <= self.final_rows, gathered, everywhere)

    def unroll(self, carry: Carry, key: jax.Array) -> tuple[Carry, tuple[Sample | Unroll, Metrics]]:
        carry, (steps, sums) = jax.lax.scan(self.env_step, carry, jax.random.split(key, self.rollout.num_steps))
        env_state, params, stats = carry
        sums = jax.tree.map(lambda x: x.sum(axis=0), sums)
        last = (env_state.observation, self.value_view(env_state.value_observation))
        if self.recompute:
            fields = {name: getattr(steps, name) for name in Unroll._fields[:-2]}
            batch_major = jax.tree.map(lambda x: jnp.swapaxes(x, 0, 1), fields)
            return carry, (Unroll(**batch_major, last_observation=last[0], last_value_observation=last[1]), sums)
        _, _, last_value = self.apply(params, stats, *last)
        advantage, target = estimate_advantages(self.returns, steps.value, last_value, steps)
        sample = Sample(
            steps.observation, steps.value_observation, steps.views, steps.action, steps.log_prob, advantage, target
        )
        return carry, (sample, sums)

    def current_advantages(
        self, params: Any, stats: RunningStatistics, batch: Unroll, value: jax.Array
    ) -> tuple[jax.Array, jax.Array]:
        """A minibatch of unrolls' advantages and targets (batch-major) from the current value network."""
        _, _, last_value = self.apply(params, stats, batch.last_observation, batch.last_value_observation)
        unrolled = batch._replace(views=None, last_observation=None, last_value_observation=None)
        time_major = jax.tree.map(lambda x: jnp.swapaxes(x, 0, 1), unrolled)
        advantage, target = estimate_advantages(self.returns, value.T, last_value, time_major)
        return jax.lax.stop_gradient((advantage.T, target.T))

    def loss(
        self, params: Any, stats: RunningStatistics, batch: Sample | Unroll, key: jax.Array
    ) -> tuple[jax.Array, Metrics]:
        mean, log_std, value = self.apply(params, stats, batch.observation, batch.value_observation, batch.views)
        if isinstance(batch, Unroll):  # the minibatches are whole unrolls exactly when advantages are recomputed
            advantage, target = self.current_advantages(params, stats, batch, value)
        else:
            advantage, target = batch.advantage, batch.target
        loss, metrics = ppo_loss(
            mean,
            log_std,
            value,
            action=batch.action,
            old_log_prob=batch.log_prob,
            advantage=advantage,
            target=target,
            key=key,
            optimization=self.optimization,
            squash_actions=self.network.squash_actions,
        )
        if self.teacher is None:
            return loss, metrics
        # the teacher sees the flat observation the policy's rollout saw (noise included, as in its own training)
        imitation = imitation_loss(mean, log_std, *self.teacher.distribution(batch.observation))
        loss = loss + self.teacher.weight * imitation
        return loss, metrics | {"loss": loss, "teacher_kl": imitation}

    def gradient_step(
        self, carry: UpdateCarry, batch_and_key: tuple[Sample | Unroll, jax.Array]
    ) -> tuple[UpdateCarry, Metrics]:
        grads, losses = jax.grad(self.loss, has_aux=True)(carry.params, carry.stats, *batch_and_key)
        grads = ordered_mean(grads, self.axis)
        adaptive, guarded = self.optimization.desired_kl > 0, self.optimization.max_kl > 0
        # the KL before this step, as every device sees it (it sets the learning rate, or stops the update)
        kl = ordered_mean(losses["approx_kl"], self.axis) if self.optimization.watches_kl else None
        with jax.named_scope("optimizer"):
            opt_state = scheduled_learning_rate(
                carry.opt_state, kl if adaptive else None, self.optimization, self.env_steps_per_gradient_step
            )
            updates, opt_state = self.optimizer.update(grads, opt_state, carry.params)
            params = optax.apply_updates(carry.params, updates)
        losses["learning_rate"] = opt_state.hyperparams["learning_rate"]
        if not guarded:
            return carry._replace(params=params, opt_state=opt_state), losses
        assert kl is not None  # a guarded update watches the KL
        stopped = carry.stopped | (kl > self.optimization.max_kl)
        # a skipped step leaves the parameters and Adam's moments as they were; its count still advances, so
        # that an annealed learning rate keeps to its schedule in environment steps
        kept_params, kept_state = jax.tree.map(
            lambda old, new: jnp.where(stopped, old, new), (carry.params, carry.opt_state), (params, opt_state)
        )
        losses["kl_stopped"] = stopped.astype(jnp.float32)
        return UpdateCarry(kept_params, kept_state._replace(count=opt_state.count), carry.stats, stopped), losses

    def updated_statistics(self, stats: RunningStatistics, samples: Sample | Unroll) -> RunningStatistics:
        """The observation statistics with this iteration's observations (every device's), when normalising."""
        if not self.network.normalize_observations:
            return stats
        return update_statistics(stats, samples.observation.reshape(-1, self.env.observation_size), self.axis)

    def epoch(self, carry: UpdateCarry, key: jax.Array, samples: Sample | Unroll) -> tuple[UpdateCarry, Metrics]:
        order_key, entropy_key = jax.random.split(key)
        order = jax.random.permutation(order_key, samples.observation.shape[0])
        shape = (self.num_minibatches, self.local_minibatch)
        minibatches = jax.tree.map(lambda x: x[order].reshape(*shape, *x.shape[1:]), samples)
        keys = jax.random.split(entropy_key, self.num_minibatches)
        # 4 gradient steps per loop trip: each trip costs loop overhead, and a longer unroll only lengthens compilation
        return jax.lax.scan(self.gradient_step, carry, (minibatches, keys), unroll=min(self.num_minibatches, 4))

    def local(
        self, params: Any, opt_state: Any, stats: RunningStatistics, filled: list[jax.Array], key: jax.Array
    ) -> tuple[Any, Any, RunningStatistics, list[jax.Array], Metrics]:
        """The iteration on this device's slice: its environments' filled leaves in and out."""
        env_state = self.empty_leaves.rebuild(filled, self.devices)
        key = jax.random.fold_in(key, jax.lax.axis_index(self.axis))
        rollout_key, epoch_key = jax.random.split(key)
        # the named scopes group the compiled program's operations in profiles (bench/ppo_profile.py)
        with jax.named_scope("rollout"):
            (env_state, _, _), (samples, sums) = jax.lax.scan(
                self.unroll,
                (env_state, params, stats),
                jax.random.split(rollout_key, self.rollout.unrolls_per_iteration),
            )
        # steps (unrolls * steps * envs, ...) or, to recompute advantages, unrolls (unrolls * envs, steps, ...)
        samples = jax.tree.map(lambda x: x.reshape(-1, *x.shape[2 if self.recompute else 3 :]), samples)
        # Brax updates the observation statistics before the epochs. With a KL guard (desired_kl or max_kl)
        # they are updated after them: the update then sees the observations as the rollout did, and the KL
        # it measures is the policy's change alone, not the statistics' drift (which alone held
        # pick-and-place's learning rate at its floor for its first 30 iterations: approx-KL 0.017-0.027 at
        # 1e-5; and reached 0.57 on a first iteration, past any sensible max_kl)
        statistics_first = not self.optimization.watches_kl
        if statistics_first:
            stats = self.updated_statistics(stats, samples)
        with jax.named_scope("update"):
            update, losses = jax.lax.scan(
                lambda carry, key: self.epoch(carry, key, samples),
                UpdateCarry(params, opt_state, stats, stopped=jnp.zeros((), bool)),
                jax.random.split(epoch_key, self.optimization.num_epochs),
            )
        params, opt_state = update.params, update.opt_state
        if not statistics_first:
            stats = self.updated_statistics(stats, samples)
        metrics = episode_metrics(jax.tree.map(lambda x: jax.lax.psum(x.sum(), self.axis), sums))
        metrics |= {name: jax.lax.pmean(value.mean(), self.axis) for name, value in losses.items()}
        leaves = jax.tree.leaves(params)
        metrics["params_finite"] = jnp.all(jnp.stack([jnp.isfinite(leaf).all() for leaf in leaves]))
        return params, opt_state, stats, EmptyLeaves.filled(env_state), metrics


def make_iteration(
    env: JaxEnv,
    *,
    rollout: RolloutSettings,
    optimization: OptimizationSettings,
    returns: ReturnSettings,
    network: NetworkSettings,
    teacher: Teacher | None = None,
) -> Callable[[TrainingState], tuple[TrainingState, Metrics]]:
    """The compiled training iteration: state -> (next state, metrics as scalars); with a `teacher`, the loss adds
    its imitation term (its parameters are constants of the program)."""
    steps = _Iteration(env, rollout, optimization, returns, network, teacher)
    replicated, split = PartitionSpec(), PartitionSpec(steps.axis)
    sharded = jax.shard_map(
        steps.local,
        mesh=env.mesh,
        in_specs=(replicated, replicated, replicated, split, replicated),
        out_specs=(replicated, replicated, replicated, split, replicated),
        check_vma=False,
    )

    def iteration(state: TrainingState) -> tuple[TrainingState, Metrics]:
        key, iteration_key = jax.random.split(state.key)
        params, opt_state, stats, filled, metrics = sharded(
            state.params, state.opt_state, state.normalizer, EmptyLeaves.filled(state.env_state), iteration_key
        )
        return TrainingState(params, opt_state, stats, steps.empty_leaves.rebuild(filled), key), metrics

    # explicit output shardings: XLA would otherwise replicate the empty per-env arrays (act, plugin_state)
    # and the next call would no longer match the compiled input shardings
    on_gpu = env.mesh.devices.flat[0].platform in ("gpu", "cuda", "rocm")
    return jax.jit(
        iteration,
        donate_argnums=0,
        out_shardings=(state_shardings(env), env.replicated),
        compiler_options=GPU_COMPILER_OPTIONS if on_gpu else None,
    )


class EmptyLeaves(NamedTuple):
    """Where an environment state has zero-size arrays (MJX's buffers for what a model lacks: actuator
    activations, tendons, mocap bodies...). They stay out of `jax.shard_map`, as XLA's GPU compiler
    (jaxlib 0.11, Shardy) crashes on a manual computation with empty per-device inputs; holding no
    values, they are made anew on the other side."""

    treedef: Any
    shapes: list[jax.ShapeDtypeStruct | None]  # of each empty leaf; None where a leaf holds values

    @staticmethod
    def of(env: JaxEnv) -> EmptyLeaves:
        leaves, treedef = jax.tree.flatten(jax.eval_shape(env.reset, jax.random.PRNGKey(0)))
        return EmptyLeaves(treedef, [leaf if math.prod(leaf.shape) == 0 else None for leaf in leaves])

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


FAILED = "failed_episodes"  # how many of the episodes that ended did so because their simulation blew up
COUNTED = "counted:"  # prefix of a sum's own episode count in `episode_sums`, where it is not all episodes'


def episode_sums(state: EnvState, reward_terms: list[str], metric_terms: list[str]) -> Metrics:
    """Per-environment sums of the statistics of the episodes that ended on this step."""
    episode = state.episode
    done = episode.done.astype(jnp.float32)
    sums = {"episodes": done, "return": episode.return_ * done, "length": episode.length * done}
    sums[FAILED] = episode.failed.astype(jnp.float32)
    sums |= {REWARD_PREFIX + name: episode.reward_terms[name] * done for name in reward_terms}
    for name in metric_terms:
        # a simulation that failed (non-finite state) ends its episode with metrics that are no numbers: each
        # metric is averaged over the episodes where it is one (else one blow-up made the mean NaN)
        value = episode.metrics[name]
        counted = episode.done & jnp.isfinite(value)
        sums[METRIC_PREFIX + name] = jnp.where(counted, value, 0.0)
        sums[COUNTED + METRIC_PREFIX + name] = counted.astype(jnp.float32)
    return sums


def episode_metrics(sums: Metrics) -> Metrics:
    """Means over the ended episodes (NaN when none ended); each metric over those where it is finite; the
    episodes' count and how many of them blew up (FAILED) as counts."""
    count, failed = sums.pop("episodes"), sums.pop(FAILED)
    counts = {name.removeprefix(COUNTED): sums.pop(name) for name in list(sums) if name.startswith(COUNTED)}
    means = {name: value / counts.get(name, count) for name, value in sums.items()}
    means["mean_return"], means["mean_length"] = means.pop("return"), means.pop("length")
    return {"episodes": count, FAILED: failed, **means}
