"""The off-policy trainers' compiled iteration: `steps_per_iteration` times, every environment steps with the
exploring actor, the step goes into the replay buffer on the device, and `updates_per_step` gradient steps follow
on minibatches of n-step transitions drawn from it. No Python runs per environment step.

It runs under `jax.shard_map` over the environments' device mesh, as PPO's iteration does: each device steps its
slice of the environments, keeps their replay and draws its share of every minibatch from it; gradients and the
observation statistics are averaged over devices in device order (`joshua_ppo.collectives`), so N GPUs act as
one N times larger.

TD3 (Fujimoto et al. 2018) as FastTD3 runs it: a deterministic tanh actor exploring with Gaussian noise whose
std each environment draws at its episode's start; clipped double-Q targets with smoothed target actions; the
actor and the target networks updated every `policy_delay`-th critic update. SAC (Haarnoja et al. 2018): a
squashed Gaussian actor exploring with its own samples, the entropy bonus in targets and actor loss, and a
temperature learned towards a target entropy; targets updated every step.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import optax
from jax.sharding import NamedSharding, PartitionSpec

from joshua_ppo.collectives import ordered_mean
from joshua_ppo.envs import EnvState, JaxEnv, env_axis
from joshua_ppo.iteration import GPU_COMPILER_OPTIONS, EmptyLeaves, episode_metrics, episode_sums
from joshua_ppo.normalizer import RunningStatistics, fresh_statistics, normalize, update_statistics
from joshua_ppo.offpolicy_losses import (
    critic_loss,
    critic_target,
    sac_actor_loss,
    td3_actor_loss,
    temperature_loss,
)
from joshua_ppo.offpolicy_networks import Actor, Critics, deterministic_action, squashed_gaussian
from joshua_ppo.offpolicy_settings import OffPolicySettings
from joshua_ppo.policy import camera_views, observation_indices
from joshua_ppo.replay import Replay, Step, add, empty_replay, sample

Metrics = dict[str, jax.Array]


class Learner(NamedTuple):
    """The networks and their optimisers: what the gradient steps change."""

    actor: Any
    critic: Any
    target_actor: Any
    target_critic: Any
    opt_state: dict[str, Any]  # "actor", "critic", "alpha"
    log_alpha: jax.Array  # SAC's temperature (TD3 keeps it at its start, unused)
    updates: jax.Array  # critic updates so far: TD3 updates its actor on every policy_delay-th


class OffPolicyState(NamedTuple):
    """Everything an iteration changes. `normalizer`, `env_state`, `key` and `params` (the actor's) mean what they
    mean in PPO's TrainingState, so the run's monitors, checkpoints and exports read either."""

    normalizer: RunningStatistics
    env_state: EnvState
    key: jax.Array
    learner: Learner
    replay: Replay
    noise_std: jax.Array  # (envs,) TD3: each environment's exploration std for its current episode

    @property
    def params(self) -> Any:
        """The actor's parameters: the policy."""
        return self.learner.actor


def make_actor(env: JaxEnv, settings: OffPolicySettings) -> Actor:
    """The actor for the environment's action size (a pixel actor: its cameras and terms checked against the
    task's, a ConfigError naming one it lacks)."""
    pixels = settings.pixels
    return Actor(
        env.action_size,
        settings.actor_hidden_sizes,
        settings.activation,
        gaussian=settings.algorithm == "sac",
        pixels=pixels,
        observation_indices=observation_indices(env, pixels, "training.offpolicy") if pixels is not None else (),
    )


def optimizers(settings: OffPolicySettings) -> dict[str, optax.GradientTransformation]:
    """Adam for the actor, the critics and SAC's temperature, after optional global-norm clipping."""

    def adam(learning_rate: float) -> optax.GradientTransformation:
        if settings.max_grad_norm is None:
            return optax.adam(learning_rate)
        return optax.chain(optax.clip_by_global_norm(settings.max_grad_norm), optax.adam(learning_rate))

    return {
        "actor": adam(settings.actor_learning_rate),
        "critic": adam(settings.critic_learning_rate),
        "alpha": adam(settings.critic_learning_rate),
    }


def _example_step(env: JaxEnv, state: EnvState, settings: OffPolicySettings) -> Step:
    """One step of every environment as the buffer stores it (shapes only matter)."""
    critic = state.value_observation
    return Step(
        observation=state.observation,
        critic_observation=critic,
        views=camera_views(state, settings.pixels),
        action=jnp.zeros((env.num_envs, env.action_size)),
        reward=state.reward,
        terminated=state.terminated,
        ended=state.terminated,
        next_observation=state.observation,
        next_critic_observation=critic,
    )


def init_state(env: JaxEnv, settings: OffPolicySettings) -> OffPolicyState:
    """Fresh networks (targets equal to them), optimisers, an empty buffer and freshly reset environments."""
    key = jax.random.PRNGKey(settings.seed)
    key, actor_key, critic_key, reset_key, noise_key = jax.random.split(key, 5)
    env_state = env.reset(reset_key)
    actor = make_actor(env, settings)
    observation = jnp.zeros((1, env.observation_size))
    views = jax.tree.map(lambda leaf: leaf[:1], camera_views(env_state, settings.pixels))
    params = actor.init(actor_key, observation, views)["params"]
    critic_observation = observation if env_state.value_observation is None else env_state.value_observation[:1]
    critic = Critics(settings.critic_hidden_sizes, settings.activation).init(
        critic_key, critic_observation, jnp.zeros((1, env.action_size))
    )["params"]
    optimizer = optimizers(settings)
    log_alpha = jnp.log(jnp.asarray(settings.initial_alpha, jnp.float32))
    target_actor, target_critic = jax.tree.map(
        jnp.copy, (params, critic)
    )  # the targets start equal, in buffers of their own
    learner = Learner(
        params,
        critic,
        target_actor,
        target_critic,
        {
            "actor": optimizer["actor"].init(params),
            "critic": optimizer["critic"].init(critic),
            "alpha": optimizer["alpha"].init(log_alpha),
        },  # fmt: skip
        log_alpha,
        jnp.zeros((), jnp.int32),
    )
    low, high = settings.exploration_std
    noise_std = jax.random.uniform(noise_key, (env.num_envs,), minval=low, maxval=high)
    replay = empty_replay(_example_step(env, env_state, settings), settings.replay_steps)
    state = OffPolicyState(fresh_statistics(env.observation_size), env_state, key, learner, replay, noise_std)
    return jax.device_put(state, state_shardings(env, state))


def _replay_sharding(env: JaxEnv) -> NamedSharding:
    """The buffer's arrays (capacity, envs, ...) keep each device's environments on it."""
    return NamedSharding(env.mesh, PartitionSpec(None, env_axis(env)))


def state_shardings(env: JaxEnv, state: Any) -> OffPolicyState:
    """Where an off-policy state lives: environments and their replay split over devices, the rest replicated."""
    replay = jax.tree.map(lambda leaf: _replay_sharding(env) if leaf.ndim >= 2 else env.replicated, state.replay)
    return OffPolicyState(env.replicated, env.sharding, env.replicated, env.replicated, replay, env.sharding)


def abstract_state(env: JaxEnv, settings: OffPolicySettings) -> OffPolicyState:
    """Shapes, dtypes and shardings of `init_state`'s result, computing nothing: enough to compile the iteration."""
    shapes = jax.eval_shape(lambda: init_state(env, settings))
    shardings = state_shardings(env, shapes)

    def placed(sharding: Any, subtree: Any) -> Any:
        return jax.tree.map(lambda leaf: jax.ShapeDtypeStruct(leaf.shape, leaf.dtype, sharding=sharding), subtree)

    return jax.tree.map(placed, shardings, shapes, is_leaf=lambda x: isinstance(x, NamedSharding))


class _Iteration:
    """The steps of one iteration on one device's slice (traced inside the shard_map)."""

    def __init__(self, env: JaxEnv, settings: OffPolicySettings) -> None:
        self.env, self.settings = env, settings
        self.axis = env_axis(env)
        self.devices = env.mesh.size
        self.local_batch = settings.batch_size // self.devices
        self.sac = settings.algorithm == "sac"
        self.actor = make_actor(env, settings)
        self.critics = Critics(settings.critic_hidden_sizes, settings.activation)
        self.optimizers = optimizers(settings)
        self.target_entropy = settings.target_entropy_scale * env.action_size
        self.empty_leaves = EmptyLeaves.of(env)
        self.reward_terms = [term.name for term in env.task.reward_terms]
        self.metric_terms = [term.name for term in env.task.metric_terms]

    def normalized(self, stats: RunningStatistics, observation: jax.Array | None) -> jax.Array | None:
        if observation is None:
            return None
        return normalize(stats, observation, self.settings.normalize_observations)

    def head(self, params: Any, stats: RunningStatistics, observation: jax.Array, views: Any) -> jax.Array:
        return self.actor.apply({"params": params}, self.normalized(stats, observation), views)  # type: ignore[return-value]  # without mutable, apply gives the output alone

    def policy(self, params: Any, stats: RunningStatistics, observation: jax.Array, views: Any, key: jax.Array):
        """A sampled action in [-1, 1] and (SAC) its log-probability; TD3's is its deterministic action."""
        head = self.head(params, stats, observation, views)
        if self.sac:
            return squashed_gaussian(head, jax.random.normal(key, head.shape[:-1] + (self.env.action_size,)))
        return deterministic_action(head, False), None

    def q(self, critic: Any, stats: RunningStatistics, observation: jax.Array, action: jax.Array) -> jax.Array:
        return self.critics.apply({"params": critic}, self.normalized(stats, observation), action)  # type: ignore[return-value]  # without mutable, apply gives the output alone

    def augmented(self, views: Any, key: jax.Array) -> Any:
        """A pixel actor's views with every image shifted at random by up to `image_shift` pixels (DrQ)."""
        shift = self.settings.image_shift
        if views is None or shift <= 0:
            return views
        images = views["images"]
        keys = jax.random.split(key, len(images))
        shifted = {name: random_shift(image, k, shift) for (name, image), k in zip(images.items(), keys, strict=True)}
        return {"images": shifted, "commands": views["commands"]}

    # --- collecting ---

    def explore(self, state: OffPolicyState, stats: RunningStatistics, key: jax.Array) -> jax.Array:
        env_state = state.env_state
        views = camera_views(env_state, self.settings.pixels)
        action, _ = self.policy(state.learner.actor, stats, env_state.observation, views, key)
        if self.sac:
            return action
        noise = jax.random.normal(key, action.shape) * state.noise_std[:, None]
        return jnp.clip(action + noise, -1.0, 1.0)

    def env_step(self, state: OffPolicyState, key: jax.Array) -> tuple[OffPolicyState, tuple[Metrics, Metrics]]:
        act_key, noise_key, update_key = jax.random.split(key, 3)
        env_state, stats = state.env_state, state.normalizer
        action = self.explore(state, stats, act_key)
        next_state = self.env.step(env_state, action)
        ended = next_state.terminated | next_state.truncated

        def after(final: jax.Array | None, current: jax.Array | None) -> jax.Array | None:
            return None if final is None or current is None else jnp.where(ended[:, None], final, current)

        step = Step(
            observation=env_state.observation,
            critic_observation=env_state.value_observation,
            views=camera_views(env_state, self.settings.pixels),
            action=action,
            reward=next_state.reward * self.settings.reward_scaling,
            terminated=next_state.terminated,
            ended=ended,
            next_observation=jnp.where(ended[:, None], next_state.final_observation, next_state.observation),
            next_critic_observation=after(next_state.final_value_observation, next_state.value_observation),
        )
        replay = add(state.replay, step)
        if self.settings.normalize_observations:
            stats = update_statistics(stats, env_state.observation, self.axis)
        low, high = self.settings.exploration_std
        fresh_std = jax.random.uniform(noise_key, ended.shape, minval=low, maxval=high)
        noise_std = jnp.where(ended, fresh_std, state.noise_std)
        learner, losses = jax.lax.cond(
            replay.count >= self.settings.learning_starts,
            lambda: self.update(state.learner, replay, stats, update_key),
            lambda: (state.learner, self.no_losses()),
        )
        sums = episode_sums(next_state, self.reward_terms, self.metric_terms)
        state = OffPolicyState(stats, next_state, state.key, learner, replay, noise_std)
        return state, (sums, losses)

    # --- learning ---

    def no_losses(self) -> Metrics:
        names = ["loss", "policy_loss", "value_loss", "q_mean", "updated"] + (["alpha", "entropy"] if self.sac else [])
        return {name: jnp.zeros(()) for name in names}

    def update(
        self, learner: Learner, replay: Replay, stats: RunningStatistics, key: jax.Array
    ) -> tuple[Learner, Metrics]:
        """`updates_per_step` gradient steps; the losses' means over them."""
        learner, losses = jax.lax.scan(
            lambda learner, key: self.gradient_step(learner, replay, stats, key),
            learner,
            jax.random.split(key, self.settings.updates_per_step),
        )
        return learner, jax.tree.map(jnp.mean, losses)

    def gradient_step(
        self, learner: Learner, replay: Replay, stats: RunningStatistics, key: jax.Array
    ) -> tuple[Learner, Metrics]:
        settings = self.settings
        sample_key, target_key, actor_key, augment_key = jax.random.split(key, 4)
        batch = sample(replay, sample_key, self.local_batch, settings.n_step, settings.gamma)
        views = self.augmented(batch.views, augment_key)
        next_views = self.augmented(batch.next_views, augment_key)
        critic_in = batch.observation if batch.critic_observation is None else batch.critic_observation
        next_critic_in = (
            batch.next_observation if batch.next_critic_observation is None else batch.next_critic_observation
        )
        alpha = jnp.exp(learner.log_alpha)

        # the critics' targets, from the target networks
        next_action, next_log_prob = self.policy(
            learner.target_actor, stats, batch.next_observation, next_views, target_key
        )
        if not self.sac:  # target policy smoothing
            noise = jnp.clip(
                jax.random.normal(target_key, next_action.shape) * settings.target_noise,
                -settings.target_noise_clip,
                settings.target_noise_clip,
            )
            next_action = jnp.clip(next_action + noise, -1.0, 1.0)
        next_q = self.q(learner.target_critic, stats, next_critic_in, next_action)
        target = critic_target(batch.reward, batch.discount, next_q, next_log_prob, alpha if self.sac else None)

        def critic_objective(critic: Any) -> tuple[jax.Array, jax.Array]:
            q = self.q(critic, stats, critic_in, batch.action)
            return critic_loss(q, target), q.mean()

        (value_loss, q_mean), grads = jax.value_and_grad(critic_objective, has_aux=True)(learner.critic)
        grads = ordered_mean(grads, self.axis)
        updates, critic_opt = self.optimizers["critic"].update(grads, learner.opt_state["critic"], learner.critic)
        critic = optax.apply_updates(learner.critic, updates)
        count = learner.updates + 1
        learner = learner._replace(critic=critic, opt_state={**learner.opt_state, "critic": critic_opt}, updates=count)

        def actor_step(learner: Learner) -> tuple[Learner, Metrics]:
            return self.actor_step(learner, batch, views, critic_in, stats, actor_key)

        if self.sac:
            learner, actor_losses = actor_step(learner)
        else:  # TD3: the actor and the targets every policy_delay-th update
            learner, actor_losses = jax.lax.cond(
                count % settings.policy_delay == 0,
                actor_step,
                lambda learner: (learner, {"policy_loss": jnp.zeros(())}),
                learner,
            )
        losses = {"loss": value_loss, "value_loss": value_loss, "q_mean": q_mean, "updated": jnp.ones(())}
        return learner, losses | actor_losses

    def actor_step(
        self, learner: Learner, batch: Any, views: Any, critic_in: jax.Array, stats: RunningStatistics, key: jax.Array
    ) -> tuple[Learner, Metrics]:
        """One step of the actor (and SAC's temperature), then the targets move towards the online networks."""
        alpha = jnp.exp(learner.log_alpha)

        def actor_objective(params: Any) -> tuple[jax.Array, jax.Array]:
            action, log_prob = self.policy(params, stats, batch.observation, views, key)
            q = self.q(learner.critic, stats, critic_in, action)
            if self.sac:
                return sac_actor_loss(q, log_prob, alpha), log_prob
            return td3_actor_loss(q), jnp.zeros(q.shape[1:])

        (policy_loss, log_prob), grads = jax.value_and_grad(actor_objective, has_aux=True)(learner.actor)
        grads = ordered_mean(grads, self.axis)
        updates, actor_opt = self.optimizers["actor"].update(grads, learner.opt_state["actor"], learner.actor)
        params = optax.apply_updates(learner.actor, updates)
        opt_state = {**learner.opt_state, "actor": actor_opt}
        log_alpha = learner.log_alpha
        losses = {"policy_loss": policy_loss}
        if self.sac:
            alpha_grad = jax.grad(temperature_loss)(log_alpha, log_prob, self.target_entropy)
            alpha_grad = ordered_mean(alpha_grad, self.axis)
            alpha_updates, alpha_opt = self.optimizers["alpha"].update(alpha_grad, opt_state["alpha"], log_alpha)
            log_alpha = optax.apply_updates(log_alpha, alpha_updates)
            opt_state["alpha"] = alpha_opt
            losses |= {"alpha": alpha, "entropy": -log_prob.mean()}
        tau = self.settings.tau
        polyak = optax.incremental_update
        learner = learner._replace(
            actor=params,
            opt_state=opt_state,
            log_alpha=log_alpha,
            target_actor=polyak(params, learner.target_actor, tau),
            target_critic=polyak(learner.critic, learner.target_critic, tau),
        )
        return learner, losses

    def local(self, state: OffPolicyState, filled: list[jax.Array]) -> tuple[OffPolicyState, list[jax.Array], Metrics]:
        """The iteration on this device's slice: its environments' filled leaves in and out."""
        env_state = self.empty_leaves.rebuild(filled, self.devices)
        key = jax.random.fold_in(state.key, jax.lax.axis_index(self.axis))
        state = state._replace(env_state=env_state)
        state, (sums, losses) = jax.lax.scan(
            self.env_step, state, jax.random.split(key, self.settings.steps_per_iteration)
        )
        metrics = episode_metrics(jax.tree.map(lambda x: jax.lax.psum(x.sum(), self.axis), sums))
        updated = jnp.maximum(losses.pop("updated").sum(), 1.0)  # the means leave out the steps before learning
        metrics |= {name: jax.lax.pmean(value.sum() / updated, self.axis) for name, value in losses.items()}
        leaves = jax.tree.leaves((state.learner.actor, state.learner.critic))
        metrics["params_finite"] = jnp.all(jnp.stack([jnp.isfinite(leaf).all() for leaf in leaves]))
        return state._replace(env_state=None), EmptyLeaves.filled(state.env_state), metrics


def random_shift(images: jax.Array, key: jax.Array, shift: int) -> jax.Array:
    """Each image of a batch (batch, H, W, C) shifted by its own random offset of up to `shift` pixels in each
    direction, the border replicated (DrQ, Kostrikov et al. 2020): the actor cannot key on exact pixel positions."""
    batch, height, width, _ = images.shape
    padded = jnp.pad(images, ((0, 0), (shift, shift), (shift, shift), (0, 0)), mode="edge")
    offsets = jax.random.randint(key, (batch, 2), 0, 2 * shift + 1)

    def crop(image: jax.Array, offset: jax.Array) -> jax.Array:
        return jax.lax.dynamic_slice(image, (offset[0], offset[1], 0), (height, width, image.shape[-1]))

    return jax.vmap(crop)(padded, offsets)


def make_iteration(
    env: JaxEnv, settings: OffPolicySettings
) -> Callable[[OffPolicyState], tuple[OffPolicyState, Metrics]]:
    """The compiled iteration: state -> (next state, metrics as scalars)."""
    steps = _Iteration(env, settings)
    split, replicated = PartitionSpec(steps.axis), PartitionSpec()
    abstract = jax.eval_shape(lambda: init_state(env, settings))
    replay_spec = jax.tree.map(
        lambda leaf: PartitionSpec(None, steps.axis) if leaf.ndim >= 2 else replicated, abstract.replay
    )
    state_spec = OffPolicyState(replicated, None, replicated, replicated, replay_spec, split)  # type: ignore[arg-type]  # a tree of specs shaped like the state
    sharded = jax.shard_map(
        steps.local,
        mesh=env.mesh,
        in_specs=(state_spec, split),
        out_specs=(state_spec, split, replicated),
        check_vma=False,
    )

    def iteration(state: OffPolicyState) -> tuple[OffPolicyState, Metrics]:
        key, iteration_key = jax.random.split(state.key)
        filled = EmptyLeaves.filled(state.env_state)
        local, filled, metrics = sharded(state._replace(env_state=None, key=iteration_key), filled)
        return local._replace(env_state=steps.empty_leaves.rebuild(filled), key=key), metrics

    on_gpu = env.mesh.devices.flat[0].platform in ("gpu", "cuda", "rocm")
    return jax.jit(
        iteration,
        donate_argnums=0,
        out_shardings=(state_shardings(env, abstract), env.replicated),
        compiler_options=GPU_COMPILER_OPTIONS if on_gpu else None,
    )
