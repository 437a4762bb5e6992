"""Batched, functional JOSHUA task environments on MJX: `reset(key) -> state`, `step(state, action) -> state`.

Both are pure JAX functions of N environments at once: jit them, `lax.scan` over them, or call them
inside `jax.shard_map` on each device's slice of the environments (`step` works on whatever slice it
is given). The task's terms run on `jax.numpy` through the same `TermContext` the CPU backend fills
with numpy, so rewards and observations match the `mujoco` backend's.

- Autoreset: an environment whose episode ended (terminated or truncated) starts a new one within
  the same `step`, from its start state `state.start`: the task's reset terms drawn for that
  environment. Of the start's Data it takes what the next `mjx.step` reads (MuJoCo's integration
  state) and what the task's terms read; the rest the step recomputes. `redraw_starts(state)` draws
  new start states for every environment (the PPO trainer does before every iteration), so episodes
  begin from fresh draws without a `mjx.forward` over the whole batch on every step.
  `state.final_observation` keeps the last observation of the ended episode (for bootstrapping
  truncated episodes), `state.episode` its return, length, per-term reward sums and final metrics.
- Rewards, terminations, truncations and the episode records follow `joshua_core.tasks.episodes`
  (the same code as the `mujoco` backend's): a simulation whose state becomes non-finite is
  terminated with zero reward, never propagated. So is one given a non-finite action (NaN or infinity), which a
  compiled step cannot refuse as the `mujoco` backend does: it is stepped with a zero action, not a clipped one,
  and its episode ends as failed (counted with the blow-ups).
- Cameras: where the task names cameras (joshua_core.tasks.cameras; MuJoCo Warp only), `state.images` holds
  each camera's current frame, rendered inside `reset` and `step` (joshua_mjx.cameras); a camera-less task
  compiles the same programs as before.
- `MjxEnv.sharding` spreads the environments over every visible device (`jax.sharding`);
  `reset` returns a state laid out that way.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from joshua_core.errors import ConfigError
from joshua_core.interfaces import EnvSpec
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_core.tasks import (
    DERIVED_FIELDS,
    KINEMATIC_FIELDS,
    MODEL_FIELDS,
    Episode,
    EpisodeSums,
    Task,
    TermContext,
    account_step,
    build_task,
    delayed_action,
    episode_params,
    load_task_spec,
    nonfinite,
    step_params,
)
from joshua_mjx.batch import STEP_INPUTS, PerEnvRandom, split_each, where_env
from joshua_mjx.cameras import Cameras
from joshua_mjx.engine import mjx_variant
from joshua_mjx.external import ExternalPhysics
from joshua_mjx.impl import WARP, CapturedGraphs, OverflowCheck, Physics, batch_data
from joshua_mjx.physics import mjx
from joshua_mjx.randomized import ModelRandomization
from joshua_mujoco import compile_model

ENV_AXIS = "envs"  # name of the device-mesh axis the environments are spread over
# The derived fields that are attributes of mjx.Data; cfrc_ext is MJX's backend-specific `_impl` field, handled
# apart. After a step only the kinematics are recomputed (mjx.kinematics): sensordata is the last physics step's,
# computed before its integration, where the `mujoco` backend recomputes sensors at the step's end.
_DATA_FIELDS = tuple(name for name in DERIVED_FIELDS if name != "cfrc_ext")
# What MuJoCo Warp's renderer reads of a Data besides the model (mjx.render), so what an autoreset takes from the
# start state where cameras render: the poses of geoms and cameras, and of lights (in MJX's `_impl`)
_RENDER_FIELDS = ("geom_xpos", "geom_xmat", "cam_xpos", "cam_xmat")
_RENDER_IMPL_FIELDS = ("light_xpos", "light_xdir")


class EnvState(NamedTuple):
    """N environments after a reset or a step; every array has the environments on its leading axis."""

    # after an autoreset, what the next step recomputes and the task does not read still describes the ended episode
    data: mjx.Data
    observation: jax.Array  # (N, obs) float32: what the policy sees next (a new episode's first one after autoreset)
    # the same without the observation noise, for a value network (asymmetric actor-critic); None when the task
    # adds no noise
    value_observation: jax.Array | None
    reward: jax.Array  # (N,) float32 reward of the last step
    terminated: jax.Array  # (N,) bool: the last step ended the episode (task termination or a non-finite state)
    truncated: jax.Array  # (N,) bool: the last step reached the episode length
    final_observation: jax.Array  # (N, obs) the last step's observation before any autoreset
    final_value_observation: jax.Array | None  # and without its noise (None as value_observation)
    action: jax.Array  # (N, nu) the last clipped action (zero after a reset)
    episode_step: jax.Array  # (N,) int32 steps taken in the current episode
    commands: dict[str, jax.Array]  # task commands (targets, goals) of the current episode
    start: mjx.Data  # where each environment's next episode starts (reset terms applied, forward done)
    start_commands: dict[str, jax.Array]  # the commands of each environment's next episode
    sums: EpisodeSums  # the current episodes' return and per-term reward sums so far
    reward_terms: dict[str, jax.Array]  # per reward term, its weighted value on the last step
    episode: Episode  # the episodes that ended on the last step
    key: jax.Array  # (N, 2) uint32 random keys of the reset terms, one per environment
    params: dict[str, jax.Array]  # domain randomization: each environment's randomized quantities (task.param_fields)
    start_params: dict[str, jax.Array]  # those of each environment's next episode
    history: jax.Array  # (N, max delay + 1, nu) the last actions, newest first (action delay)
    strength: jax.Array  # (N,) float32 each environment's event strength (the randomization curriculum's; else 1)
    # each camera's current frame by camera name, (N, height, width, channels): rgb uint8, depth float32 metres,
    # segmentation int32 geom ids (joshua_core.tasks.cameras); MjxEnv.cameras.bytes_per_env bytes per
    # environment. {} when the task names no camera. A camera rendering every k steps holds its frame in
    # between, so after an autoreset it may still show the ended episode until its next render.
    images: dict[str, jax.Array]
    # (N,) int32 environment steps since reset modulo the cameras' common period, the same in every environment:
    # a camera renders where it is a multiple of its `every`; None when the task names no camera
    camera_step: jax.Array | None


class MjxEnv:
    """A task on `num_envs` MJX simulations (EnvKind.JAX); see the module docstring."""

    def __init__(
        self,
        task: Task,
        model: mujoco.MjModel,
        num_envs: int,
        *,
        source: str | Path = "<model>",
        devices: Sequence[jax.Device] | None = None,
        desync_episodes: bool = False,
        curriculum: bool = False,
        physics: Physics | None = None,
        external: ExternalPhysics | None = None,
    ) -> None:
        devices = list(devices or jax.devices())
        self.physics = physics = physics or Physics()
        physics.check_devices(devices)
        self.external = external
        if external is not None:
            _check_external(external, task, physics, devices)
        if num_envs % len(devices):
            raise ConfigError(
                f"num_envs {num_envs} must be a multiple of the {len(devices)} devices it is spread over "
                f"({', '.join(str(device) for device in devices)})"
            )
        self.task = task
        self.model = model
        self.source = Path(source)
        self.num_envs = num_envs
        if task.cameras and physics.impl == WARP and len(devices) > 1:
            raise ConfigError(
                f"task '{task.name}' renders cameras: their renderer runs on one device, not {len(devices)}; "
                "set CUDA_VISIBLE_DEVICES to one GPU"
            )
        # the model and the initial state are constants of the compiled functions: on a device of this process
        locals_ = [device for device in devices if device.process_index == jax.process_index()]
        locals_ = locals_ or jax.local_devices()[:1]
        local = locals_[0]
        self._contact_forces = "cfrc_ext" in task.fields
        # Warp computes cfrc_ext within its step when asked to; MJX-JAX by rne_postconstraint (_external_forces)
        self.mjx_model = physics.put_model(model, source, locals_, run_rne_postconstraint=self._contact_forces)
        self.mesh = Mesh(np.array(devices), (ENV_AXIS,))
        self.sharding = NamedSharding(self.mesh, PartitionSpec(ENV_AXIS))
        self.replicated = NamedSharding(self.mesh, PartitionSpec())
        self.observation_size = task.observation_size
        self.action_size = task.action_size
        self._derived = tuple(name for name in _DATA_FIELDS if name in task.fields)
        # the renderer reads geom poses: recomputed for the positions the step ends at, as the task's terms see them
        self._kinematics_after_step = bool(KINEMATIC_FIELDS & task.fields) or bool(task.cameras)
        initial = mujoco.MjData(model)
        if task.keyframe_id >= 0:
            mujoco.mj_resetDataKeyframe(model, initial, task.keyframe_id)
        self._initial_data = physics.put_data(model, initial, local, num_envs // len(devices))
        self.randomization = ModelRandomization(task, model, self.mjx_model, local)
        self._overflow = OverflowCheck(physics, model)
        self.cameras = Cameras(task.name, task.cameras, model, num_envs, physics) if task.cameras else None
        self._graphs = CapturedGraphs(physics, local)
        self.desync_episodes = desync_episodes
        self.curriculum = task.curriculum if curriculum else None  # EnvSpec.curriculum
        self._draw_starts = jax.jit(self._fresh_episodes, in_shardings=self.sharding, out_shardings=self.sharding)
        self._split_keys = jax.jit(split_each, in_shardings=self.sharding, out_shardings=self.sharding)
        self._begin = jax.jit(self._begin_episodes, out_shardings=self.sharding)
        self.step = jax.jit(self._step)

    # --- the functional API -------------------------------------------------------------------

    def reset(self, key: jax.Array) -> EnvState:
        """Every environment at the start of a fresh episode (reset terms drawn from `key`); the same
        draws are each environment's start state until `redraw_starts`."""
        keys, draw = self._split_keys(jax.random.split(key, self.num_envs))
        start = self.curriculum.start if self.curriculum else 1.0
        strength = jnp.full(self.num_envs, start, jnp.float32)  # laid out by _draw_starts and _begin
        data, commands, params = self._draw_starts(draw, strength)
        steps = jnp.zeros(self.num_envs, jnp.int32)
        if self.desync_episodes:  # first episodes start at random steps (see EnvSpec.desync_episodes)
            steps = jax.random.randint(jax.random.fold_in(key, 1), (self.num_envs,), 0, self.task.episode_length)
        return self._begin(data, commands, params, keys, steps, strength)

    def redraw_starts(self, state: EnvState) -> EnvState:
        """`state` with a new start state for every environment, drawn from its reset terms.

        Call it between rollouts (the PPO trainer does before every iteration): it runs `mjx.forward`
        once over the batch, which `step` would otherwise run on every step that ends an episode
        anywhere in the batch, and it stays out of the compiled rollout. With MuJoCo Warp it is also where a
        capacity overflow is reported (once, `joshua_mjx.impl.OverflowCheck`) and where captured CUDA graphs are
        cleared now and then (`joshua_mjx.impl.CapturedGraphs`)."""
        self._overflow.watch(state.data)
        self._graphs.between_rollouts(state.data)
        keys, draw = self._split_keys(state.key)
        start, start_commands, start_params = self._draw_starts(draw, state.strength)
        return state._replace(start=start, start_commands=start_commands, start_params=start_params, key=keys)

    def metrics(self, state: EnvState) -> dict[str, jax.Array]:
        """The task's metrics (its METRIC terms, e.g. "success"), (N,) each by name, of the environments' current
        state, as the CPU backend reports them in infos["metrics"]; a term that reads the previous step's positions
        or action sees the current ones. A pure function: jit it or call it inside a compiled one."""
        ctx = self._context(
            state.data,
            state.data.qpos,
            state.action,
            state.action,
            state.episode_step,
            state.commands,
            state.params,
            state.strength,
        )
        return self.task.metrics(ctx)

    def _begin_episodes(
        self,
        data: mjx.Data,
        commands: dict[str, jax.Array],
        params: dict[str, jax.Array],
        keys: jax.Array,
        episode_step: jax.Array,
        strength: jax.Array,
    ) -> EnvState:
        """The environments at the step `episode_step` of episodes started from `data`, which are also their
        start states."""
        n = self.num_envs
        zeros = jnp.zeros(n, jnp.float32)
        action = jnp.zeros((n, self.action_size), jnp.float32)
        observation, value_observation = self._observe(
            self._context(data, data.qpos, action, action, episode_step, commands, params, strength)
        )
        sums = EpisodeSums.zeros(jnp, self.task, n, jnp.float32)
        images: dict[str, jax.Array] = {}
        camera_step: jax.Array | None = None
        if self.cameras:
            fields = self.randomization.model_params(params)
            images, data = self.cameras.render(lambda f, d: self._physics(f, fields, d), data)
            camera_step = jnp.zeros(n, jnp.int32)
        return EnvState(
            data=data,
            observation=observation,
            value_observation=value_observation,
            reward=zeros,
            terminated=jnp.zeros(n, bool),
            truncated=jnp.zeros(n, bool),
            final_observation=observation,
            final_value_observation=value_observation,
            action=action,
            episode_step=episode_step,
            commands=commands,
            start=data,
            start_commands=commands,
            sums=sums,
            reward_terms=sums.reward_terms,
            episode=Episode.none(jnp, self.task, n, jnp.float32),
            key=keys,
            params=params,
            start_params=params,
            history=jnp.zeros((n, self.task.max_action_delay + 1, self.action_size), jnp.float32),
            strength=strength,
            images=images,
            camera_step=camera_step,
        )

    def _step(self, state: EnvState, action: jax.Array) -> EnvState:
        """Apply `action` (N, nu; clipped to [-1, 1]), advance frame_skip physics steps, evaluate the task,
        and start a new episode wherever one ended. An environment whose action is not finite fails the step."""
        task = self.task
        action = action.astype(jnp.float32)
        finite = jnp.isfinite(action).all(axis=1)
        action = jnp.where(finite[:, None], jnp.clip(action, -1.0, 1.0), 0.0)
        applied, history = action, state.history
        if task.max_action_delay:
            applied, history = delayed_action(jnp, history, action, state.params["action_delay"])
        ctrl = task.action_to_ctrl(jnp, applied, state.params, state.data.ctrl)
        data = state.data.replace(ctrl=ctrl.astype(state.data.ctrl.dtype))
        if "xfrc_applied" in state.params:
            data = data.replace(xfrc_applied=state.params["xfrc_applied"].astype(data.xfrc_applied.dtype))
        fields = self.randomization.model_params(state.params)
        data = self._advance(fields, data)
        if self._kinematics_after_step:
            data = self._physics(mjx.kinematics, fields, data)
        if self._contact_forces:
            data = self._external_forces(fields, data)
        episode_step = state.episode_step + 1
        params, key = state.params, state.key
        if task.interval_events or "xfrc_applied" in params:
            random = PerEnvRandom(key)
            ctx = self._context(
                data, state.data.qpos, action, state.action, episode_step, state.commands, params, state.strength
            )
            params, key = step_params(task, ctx.replace(random=random)), random.keys
            if self.randomization.derives_on_steps:
                params = self.randomization.with_derived(params)
        ctx = self._context(
            data, state.data.qpos, action, state.action, episode_step, state.commands, params, state.strength
        )
        failed = nonfinite(jnp, data.qpos, data.qvel) | ~finite
        outcome = account_step(task, ctx, failed, state.sums, jnp.float32)
        done = outcome.episode.done
        final_observation, final_value_observation = self._observe(ctx)
        strength = state.strength
        if self.curriculum:  # the next episodes draw their events at the strengths these episodes earned
            strength = self.curriculum.next_strength(
                jnp, strength, done, outcome.episode.metrics[self.curriculum.metric]
            )

        data = self._autoreset(done, state.start, data)
        commands = where_env(done, state.start_commands, state.commands)
        params = where_env(done, state.start_params, params)
        history = jnp.where(done[:, None, None], 0.0, history)
        action = jnp.where(done[:, None], 0.0, action)
        previous_action = jnp.where(done[:, None], 0.0, state.action)
        episode_step = jnp.where(done, 0, episode_step)
        previous_qpos = jnp.where(done[:, None], data.qpos, state.data.qpos)
        images, camera_step = state.images, state.camera_step
        if self.cameras:
            assert camera_step is not None  # a state of an environment with cameras counts their steps
            camera_step = (camera_step + 1) % self.cameras.period
            fields = self.randomization.model_params(params)
            images, data = self.cameras.update(lambda f, d: self._physics(f, fields, d), data, camera_step, images)
        observation, value_observation = self._observe(
            self._context(data, previous_qpos, action, previous_action, episode_step, commands, params, strength)
        )
        return EnvState(
            data=data,
            observation=observation,
            value_observation=value_observation,
            reward=outcome.reward,
            terminated=outcome.terminated,
            truncated=outcome.truncated,
            final_observation=final_observation,
            final_value_observation=final_value_observation,
            action=action,
            episode_step=episode_step,
            commands=commands,
            start=state.start,
            start_commands=state.start_commands,
            sums=outcome.sums,
            reward_terms=outcome.reward_terms,
            episode=outcome.episode,
            key=key,
            params=params,
            start_params=state.start_params,
            history=history,
            strength=strength,
            images=images,
            camera_step=camera_step,
        )

    # --- pieces -------------------------------------------------------------------------------

    def _physics(self, function: Any, fields: dict[str, jax.Array], data: mjx.Data) -> mjx.Data:
        """`function(model, data)` of every environment, each on its model (its randomized fields); named
        "physics" in profiles (bench/ppo_profile.py)."""
        with jax.named_scope("physics"):
            if not fields:
                return self._on_each_device(lambda d: jax.vmap(function, (None, 0))(self.mjx_model, d))(data)
            return self._on_each_device(jax.vmap(lambda f, d: function(self.randomization.model(f), d)))(fields, data)

    def _on_each_device(self, function: Callable[..., Any]) -> Callable[..., Any]:
        """`function` of a batch of environments, run by each device on its own slice where MuJoCo Warp steps
        several devices' environments and the caller is not one device's slice already (inside `jax.shard_map`,
        as the PPO iteration is). Warp's Data shares one contact array and its counters among the environments
        it steps together, which the compiler cannot split along the environments' axis: each device holds its
        own (`_initial_batch`), and its own calls read and write them. Otherwise `function` itself."""
        if self.physics.impl != WARP or self.mesh.size == 1 or ENV_AXIS in jax.sharding.get_abstract_mesh().manual_axes:
            return function
        split = PartitionSpec(ENV_AXIS)
        return jax.shard_map(function, mesh=self.mesh, in_specs=split, out_specs=split, check_vma=False)

    def _initial_batch(self, n: int) -> mjx.Data:
        """`n` environments' initial Data; where MuJoCo Warp steps several devices' environments, each device makes
        its own share, with its own contact arrays and counters (see `_on_each_device`)."""
        return self._on_each_device(lambda rows: batch_data(self._initial_data, rows.shape[0]))(jnp.zeros(n))

    def _advance(self, fields: dict[str, jax.Array], data: mjx.Data) -> mjx.Data:
        """`data` after frame_skip physics steps. Only MuJoCo's integration state goes from one to the next: what
        else the steps before the last compute, the last recomputes, so XLA drops it (positions of cameras and
        geoms, inertias, constraint rows, ... stay on chip or go unwritten, which saves memory traffic). The
        Data is what frame_skip whole steps give, to float32 rounding (XLA may fuse the two programs differently).
        An external physics steps the whole batch itself."""
        if self.external is not None:
            with jax.named_scope("physics"):
                return self.external.advance(data, self.task.frame_skip, fields)
        if self.physics.impl == WARP:
            # Warp's FFI step rewrites every field of the Data it is given, so whatever the loop does not carry
            # XLA copies into each call: carrying the whole Data is the lean path there (bench/mjx_env_cost.py)
            return jax.lax.fori_loop(0, self.task.frame_skip, lambda _, d: self._physics(mjx.step, fields, d), data)

        def inputs_step(_: int, inputs: dict[str, jax.Array]) -> dict[str, jax.Array]:
            stepped = self._physics(mjx.step, fields, data.replace(**inputs))
            return {name: getattr(stepped, name) for name in STEP_INPUTS}

        first = {name: getattr(data, name) for name in STEP_INPUTS}
        inputs = jax.lax.fori_loop(0, self.task.frame_skip - 1, inputs_step, first)
        return self._physics(mjx.step, fields, data.replace(**inputs))

    def _external_forces(self, fields: dict[str, jax.Array], data: mjx.Data) -> mjx.Data:
        """`data` with rne_postconstraint's cfrc_ext (contact and applied forces on each body), which the terms
        read. Its other outputs (cacc, cfrc_int: two passes over the body tree) are not kept, so XLA drops them.
        MuJoCo Warp computes cfrc_ext within its step and forward (run_rne_postconstraint, set in __init__), an
        external physics within its step (a start state has none: nothing touches it before its first step)."""
        if self.physics.impl == WARP or self.external is not None:
            return data
        cfrc_ext = self._physics(mjx.rne_postconstraint, fields, data)._impl.cfrc_ext
        return data.replace(_impl=data._impl.replace(cfrc_ext=cfrc_ext))

    def _autoreset(self, done: jax.Array, start: mjx.Data, data: mjx.Data) -> mjx.Data:
        """`data` with the start state of every environment whose episode ended (`done`): of the start's Data only
        what the next mjx.step reads and what the task's terms read. The rest, which the step recomputes, keeps
        the ended episode's values until then, since copying all of it costs time on every step."""
        names = STEP_INPUTS + self._derived + (_RENDER_FIELDS if self.cameras else ())
        data = data.replace(**{name: where_env(done, getattr(start, name), getattr(data, name)) for name in names})
        if self.cameras:
            lights = {
                name: where_env(done, getattr(start._impl, name), getattr(data._impl, name))
                for name in _RENDER_IMPL_FIELDS
            }
            data = data.replace(_impl=data._impl.replace(**lights))
        if self._contact_forces:
            cfrc_ext = where_env(done, start._impl.cfrc_ext, data._impl.cfrc_ext)
            data = data.replace(_impl=data._impl.replace(cfrc_ext=cfrc_ext))
        return data

    def _fresh_episodes(
        self, keys: jax.Array, strength: jax.Array
    ) -> tuple[mjx.Data, dict[str, jax.Array], dict[str, jax.Array]]:
        """New episodes, one per key: the task's initial state with its reset terms and reset events applied
        (at each environment's `strength`), forward done."""
        task, n = self.task, keys.shape[0]
        ctx = task.reset(task.reset_context(jnp, n, PerEnvRandom(keys)))
        ctx = ctx.replace(strength=strength if self.curriculum else None)
        params = self.randomization.with_derived(episode_params(task, ctx))
        data = self._initial_batch(n)
        dtype = data.qpos.dtype
        data = data.replace(
            qpos=ctx.qpos.astype(dtype),
            qvel=ctx.qvel.astype(dtype),
            ctrl=task.reset_ctrl(jnp, n, params).astype(dtype),
        )
        if self.external is not None:
            data = self.external.start(data)
        fields = self.randomization.model_params(params)
        data = self._physics(mjx.forward, fields, data)
        if self._contact_forces:
            data = self._external_forces(fields, data)
        return data, {name: value.astype(jnp.float32) for name, value in ctx.commands.items()}, params

    def _context(
        self,
        data: mjx.Data,
        previous_qpos: jax.Array,
        action: jax.Array,
        previous_action: jax.Array,
        episode_step: jax.Array,
        commands: dict[str, jax.Array],
        params: dict[str, jax.Array],
        strength: jax.Array,
    ) -> TermContext:
        derived = {name: getattr(data, name) for name in self._derived}
        if self._contact_forces:
            derived["cfrc_ext"] = data._impl.cfrc_ext  # MJX keeps backend-specific fields in `_impl`
        return TermContext(
            xp=jnp,
            dt=self.task.dt,
            qpos=data.qpos,
            qvel=data.qvel,
            prev_qpos=previous_qpos,
            ctrl=data.ctrl,
            action=action,
            prev_action=previous_action,
            episode_step=episode_step,
            commands=commands,
            params=params,
            defaults=self.task.defaults,
            strength=strength if self.curriculum else None,
            **derived,
        )

    def _observe(self, ctx: TermContext) -> tuple[jax.Array, jax.Array | None]:
        """The policy's observation and, where the task adds observation noise, the value network's (without it;
        XLA computes the terms once for both)."""

        def finite(noise: bool) -> jax.Array:
            observation = self.task.observe(ctx, noise).astype(jnp.float32)
            return jnp.nan_to_num(observation, posinf=0.0, neginf=0.0)

        return finite(True), finite(False) if self.task.noisy_observations else None


def _check_external(external: ExternalPhysics, task: Task, physics: Physics, devices: list[jax.Device]) -> None:
    """Refuse, in one line each, what an external physics cannot step: several devices, cameras (MuJoCo Warp's
    renderer draws MuJoCo's state), MuJoCo Warp beside it, a derived field it does not give, a randomized model
    field it does not take."""
    if len(devices) > 1:
        raise ConfigError(
            f"task '{task.name}': its physics steps the environments on one device, not {len(devices)}; "
            "set CUDA_VISIBLE_DEVICES to one GPU"
        )
    if task.cameras or physics.impl == WARP:
        raise ConfigError(f"task '{task.name}': cameras and MuJoCo Warp need MuJoCo's physics")
    missing = sorted((set(DERIVED_FIELDS) - KINEMATIC_FIELDS - external.gives) & task.fields)
    if missing:
        raise ConfigError(f"task '{task.name}': its terms read {', '.join(missing)}, which its physics does not give")
    refused = sorted(name for name in task.param_fields if name in MODEL_FIELDS and name not in external.randomizable)
    if refused:
        taken = ", ".join(sorted(external.randomizable)) or "none"
        raise ConfigError(
            f"task '{task.name}': its events randomize {', '.join(refused)}, which its physics does not take "
            f"per environment (it takes {taken})"
        )


def make_mjx_env(
    task: str,
    num_envs: int,
    *,
    model_path: str | Path | None = None,
    plugins: PluginHost | None = None,
    task_config: Any = None,
    devices: list[jax.Device] | None = None,
    physics: Physics | None = None,
) -> MjxEnv:
    """An MjxEnv of `num_envs` copies of the registered `task`.

    `model_path` replaces the task's model; without it the task's model is used, or rather its MJX
    variant (`scene_mjx.xml` beside `scene.xml`) when there is one. `task_config` is a `joshua.TaskConfig`;
    the environments are spread over `devices` (default: every visible device). `physics`: the implementation
    that steps them (default: MJX-JAX; `Physics("warp")` for MuJoCo Warp).
    """
    path = resolve_data_path(model_path) if model_path else None
    spec = EnvSpec(task, num_envs, model_path=path, task_config=task_config, devices=devices)
    return mjx_envs(spec, plugins or PluginHost.discover(), physics)


def mjx_envs(spec: EnvSpec, plugins: PluginHost, physics: Physics | None = None) -> MjxEnv:
    """The MjxEnv an EnvSpec describes (the `mjx` backend's EnvKind.JAX environments); `physics` replaces the
    one its training config names (`training.mjx`)."""
    task_spec = load_task_spec(spec.task, plugins)
    path = spec.model_path or mjx_variant(task_spec.model_path)
    model = compile_model(path, plugins=plugins)
    built = build_task(task_spec, model, plugins, spec.task_config)
    return MjxEnv(
        built,
        model,
        spec.num_envs,
        source=path,
        devices=spec.devices,
        desync_episodes=spec.desync_episodes,
        curriculum=spec.curriculum,
        physics=physics or Physics.from_training(spec.training),
    )
