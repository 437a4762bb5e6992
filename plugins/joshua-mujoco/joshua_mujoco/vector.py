"""Batched CPU environments: any JOSHUA task on N MuJoCo simulations stepped by `mujoco.batch`.

`BatchedSimulation` holds the N simulations and evaluates the task's terms with numpy over the
whole batch (no per-environment Python loop). `BatchedVectorEnv` is the Gymnasium `VectorEnv`
on top of it, with same-step autoreset; `joshua_mujoco.envs` registers single environments.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from joshua_render import choose_headless_gl

choose_headless_gl()  # before mujoco is imported, so that render_frame works without a display

import gymnasium  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from gymnasium.vector import AutoresetMode, VectorEnv  # noqa: E402
from gymnasium.vector.utils import batch_space  # noqa: E402
from numpy.typing import NDArray  # noqa: E402

from joshua_core.config_pb2 import TaskConfig, TrainingConfig  # noqa: E402
from joshua_core.defaults import DEFAULT_NUMPY_NUM_ENVS  # noqa: E402
from joshua_core.interfaces import DEFAULT_RENDER_HEIGHT, DEFAULT_RENDER_WIDTH, EnvSpec  # noqa: E402
from joshua_core.plugins import PluginHost  # noqa: E402
from joshua_core.resources import resolve_data_path  # noqa: E402
from joshua_core.tasks import (  # noqa: E402
    DERIVED_FIELDS,
    INERTIAL_FIELDS,
    MODEL_FIELDS,
    REWARD_PREFIX,
    EpisodeSums,
    NumpyRandom,
    Task,
    TermContext,
    account_step,
    build_task,
    delayed_action,
    episode_params,
    load_task_spec,
    nonfinite,
    step_params,
    tiled,
)
from joshua_mujoco.models import compiled, read_spec  # noqa: E402
from joshua_mujoco.physics import BatchPhysics, MuJoCoBatchPhysics  # noqa: E402
from joshua_mujoco.task_options import task_config_from_options  # noqa: E402
from joshua_render import camera_id, create_renderer, render_with_commands  # noqa: E402

# A sensor that makes MuJoCo compute cfrc_ext (mj_rnePostConstraint) inside every step.
_CONTACT_FORCE_SENSOR = "joshua_contact_forces"


def load_task_model(
    task: str, model_path: Path | None, plugins: PluginHost, config: TaskConfig | None
) -> tuple[Task, mujoco.MjModel]:
    """The built task and its compiled model (`model_path` is resolved already; None: the task's own model).

    If the task reads contact forces, a sensor is added that makes every step compute them, as
    Gymnasium's mujoco environments do by calling mj_rnePostConstraint after each step.
    """
    spec = load_task_spec(task, plugins)
    path = model_path or resolve_data_path(spec.model_path)
    model_spec = read_spec(path, plugins)
    model = compiled(path, model_spec.compile)
    built = build_task(spec, model, plugins, config)
    if "cfrc_ext" in built.fields and model.nbody > 1:
        model_spec.add_sensor(
            name=_CONTACT_FORCE_SENSOR,
            type=mujoco.mjtSensor.mjSENS_FRAMELINACC,
            objtype=mujoco.mjtObj.mjOBJ_BODY,
            objname=model.body(1).name,
        )
        model = compiled(path, model_spec.compile)
        built = build_task(spec, model, plugins, config)
    # A diverging simulation becomes non-finite and is terminated, instead of MuJoCo resetting it silently.
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    return built, model


class BatchedSimulation:
    """N simulations of one task: reset some, step all, evaluate the task's terms on the batch.

    Holds the per-environment state the terms read besides the physics' (actions, previous qpos,
    episode step, commands) in numpy arrays with the environments on the leading axis. The physics is
    `mujoco.batch` unless another `BatchPhysics` of the same model is given.
    """

    def __init__(
        self,
        task: Task,
        model: mujoco.MjModel,
        num_envs: int,
        *,
        seed: int = 0,
        nthread: int | None = None,
        physics: BatchPhysics | None = None,
        curriculum: bool = False,
    ) -> None:
        self.task = task
        self.model = model
        self.num_envs = num_envs
        self.physics = physics or MuJoCoBatchPhysics(model, num_envs, task.fields, nthread)
        self.qpos = self.physics.field("qpos")
        self.qvel = self.physics.field("qvel")
        self.ctrl = self.physics.field("ctrl")
        self.derived = {name: self.physics.field(name) for name in DERIVED_FIELDS if name in task.fields}
        self.prev_qpos = np.zeros_like(self.qpos)
        self.action = np.zeros((num_envs, task.action_size))
        self.prev_action = np.zeros_like(self.action)
        self.episode_step = np.zeros(num_envs, dtype=np.int64)
        self.commands = {name: np.zeros((num_envs, size)) for name, size in task.commands.items()}
        # domain randomization: each simulation's randomized quantities, its own model fields, the pushes
        self.params = {
            name: np.array(value) for name, value in tiled(np, task.defaults, num_envs, task.param_fields).items()
        }
        self.model_fields = {name: self.physics.model_field(name) for name in task.param_fields if name in MODEL_FIELDS}
        # each simulation's event strength under the task's randomization curriculum (None: full strength)
        self.curriculum = task.curriculum if curriculum else None
        self.strength = None if self.curriculum is None else np.full(num_envs, self.curriculum.start)
        self.xfrc_applied = self.physics.field("xfrc_applied") if "xfrc_applied" in self.params else None
        self.history = np.zeros((num_envs, task.max_action_delay + 1, task.action_size))
        self.seed(seed)

    def seed(self, seed: int | Sequence[int] | None) -> None:
        """Restart the random stream of reset terms."""
        self.random = NumpyRandom(np.random.default_rng(seed))

    def context(self) -> TermContext:
        """The whole batch as a TermContext (live views: valid until the next step or reset)."""
        return TermContext(
            xp=np,
            dt=self.task.dt,
            qpos=self.qpos,
            qvel=self.qvel,
            prev_qpos=self.prev_qpos,
            ctrl=self.ctrl,
            action=self.action,
            prev_action=self.prev_action,
            episode_step=self.episode_step,
            commands=self.commands,
            params=self.params,
            defaults=self.task.defaults,
            strength=self.strength,
            **self.derived,
        )

    def subset_context(self, ids: NDArray[np.intp]) -> TermContext:
        """The environments `ids` as a TermContext of copies."""
        ctx = self.context()
        arrays = {
            name: getattr(ctx, name)[ids]
            for name in ("qpos", "qvel", "prev_qpos", "ctrl", "action", "prev_action", "episode_step", *self.derived)
        }
        return ctx.replace(
            commands={name: value[ids] for name, value in self.commands.items()},
            params={name: value[ids] for name, value in self.params.items()},
            strength=self.strengths(ids),
            **arrays,
        )

    def strengths(self, ids: NDArray[np.intp]) -> NDArray[np.float64] | None:
        """The randomization strengths of the environments `ids`; None without a curriculum."""
        return None if self.strength is None else self.strength[ids]

    def reset(self, ids: NDArray[np.intp]) -> NDArray[np.float64]:
        """Reset the environments `ids` (initial state, then the task's reset terms); return their observations."""
        task = self.task
        self.physics.reset(ids, task.keyframe_id)
        state = task.reset(task.reset_context(np, len(ids), self.random))
        self.qpos[ids] = state.qpos
        self.qvel[ids] = state.qvel
        for name, value in self.commands.items():
            value[ids] = state.commands[name]
        drawn = episode_params(task, state.replace(strength=self.strengths(ids)))
        for name, value in drawn.items():
            self.params[name][ids] = value
        self.ctrl[ids] = task.reset_ctrl(np, len(ids), drawn)
        self.write_model(ids)
        self.history[ids] = 0.0
        self.physics.forward(ids)
        self.prev_qpos[ids] = self.qpos[ids]
        self.action[ids] = 0.0
        self.prev_action[ids] = 0.0
        self.episode_step[ids] = 0
        return task.observe(self.subset_context(ids))

    def step(self, actions: Any) -> NDArray[np.bool_]:
        """Apply actions (clipped to [-1, 1]) and advance every environment by frame_skip physics steps.

        Returns which environments failed (a MuJoCo error, or a non-finite state).
        """
        if np.iscomplexobj(actions):  # float64 conversion would drop the imaginary part with only a warning
            raise ValueError("step expects real actions, got complex values")
        action = np.asarray(actions, dtype=np.float64)
        if action.size != self.action.size:
            raise ValueError(
                f"step expects actions of shape ({self.num_envs}, {self.task.action_size}), got {np.shape(actions)}"
            )
        action = action.reshape(self.action.shape)
        if not np.isfinite(action).all():
            bad = np.flatnonzero(~np.isfinite(action).all(axis=1))
            raise ValueError(f"actions contain NaN or infinity for environments {bad.tolist()[:10]}")
        self.prev_action[:] = self.action
        np.clip(action, -1.0, 1.0, out=self.action)
        self.prev_qpos[:] = self.qpos
        applied = self.action
        if self.task.max_action_delay:
            applied, self.history = delayed_action(np, self.history, self.action, self.params["action_delay"])
        self.ctrl[:] = self.task.action_to_ctrl(np, applied, self.params, self.ctrl)
        if self.xfrc_applied is not None:
            self.xfrc_applied[:] = self.params["xfrc_applied"]
        failed = self.physics.step(self.task.frame_skip)
        self.episode_step += 1
        self._step_events()
        return failed | nonfinite(np, self.qpos, self.qvel)

    def follow_curriculum(self, ended: NDArray[np.bool_], metrics: dict[str, Any]) -> None:
        """Move the event strengths of the simulations whose episodes `ended` by the curriculum's metric."""
        if self.curriculum is not None and self.strength is not None:
            metric = metrics[self.curriculum.metric]
            self.strength = self.curriculum.next_strength(np, self.strength, ended, metric)

    def write_model(self, ids: NDArray[np.intp]) -> None:
        """Give the simulations `ids` their randomized model fields, and recompute what MuJoCo derives from
        masses and armature (mj_setConst: the bodies' and dofs' inverse weights)."""
        for name, field in self.model_fields.items():
            field[ids] = self.params[name][ids]
        if INERTIAL_FIELDS & self.model_fields.keys() and len(ids):
            self.physics.set_const(ids)

    def _step_events(self) -> None:
        """End the pushes of the step and run the interval events that are due (see step_params)."""
        if not self.task.interval_events and self.xfrc_applied is None:
            return
        ctx = self.context().replace(random=self.random)
        self.params = {name: np.array(value) for name, value in step_params(self.task, ctx).items()}
        due = np.zeros(self.num_envs, dtype=bool)
        for event in self.task.interval_events:
            due |= self.episode_step % event.interval == 0
        if self.model_fields:
            self.write_model(np.flatnonzero(due))

    def render(self, env_index: int, camera: str | int | None, width: int, height: int) -> NDArray[np.uint8]:
        """An RGB image of one environment, with its 3-d commands (targets, goals) drawn (see render_with_commands)."""
        if not 0 <= env_index < self.num_envs:
            raise IndexError(f"env_index {env_index} out of range for {self.num_envs} environments")
        renderers = self.__dict__.setdefault("_renderers", {})
        model, data = self.physics.model_and_data(env_index)
        if (width, height) not in renderers:
            renderers[(width, height)] = create_renderer(model, width, height)
        renderer = renderers[(width, height)]
        if camera is None:
            camera = camera_id(model, None)
        commands = {name: value[env_index] for name, value in self.commands.items()}
        return render_with_commands(renderer, model, data, camera, commands)

    def close(self) -> None:
        for renderer in self.__dict__.pop("_renderers", {}).values():
            renderer.close()
        self.physics.close()


class BatchedVectorEnv(VectorEnv):
    """A Gymnasium VectorEnv over `mujoco.batch`, running any registered task (EnvKind.NUMPY).

    - Spaces: float32 Boxes; actions in [-1, 1] (values outside are clipped; NaN or infinity is a ValueError).
    - Autoreset: same step. For an environment that finished, step() returns the first
      observation of its next episode; the last one is in infos["final_obs"] (num_envs x obs_dim,
      rows valid where infos["_final_obs"]).
    - infos["reward_terms"]: each reward term's weighted value of this step, (num_envs,) arrays.
    - infos["metrics"]: the task's metrics (e.g. "distance", "success") of this step.
    - infos["episode"]: on the step an episode ends, "r" (return), "l" (length),
      "reward/<term>" (sum of that term over the episode) and "failed" (its simulation blew up), valid where
      infos["_episode"].
    - Rewards, terminations, truncations and the episode records follow `joshua_core.tasks.episodes`.
    """

    metadata: dict[str, Any] = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": ["rgb_array"]}

    def __init__(
        self, simulation: BatchedSimulation, render_mode: str | None = None, *, desync_episodes: bool = False
    ) -> None:
        self.simulation = simulation
        self.desync_episodes = desync_episodes
        self.task = simulation.task
        self.num_envs = simulation.num_envs
        self.render_mode = render_mode
        self.metadata = {**type(self).metadata, "render_fps": round(1.0 / self.task.dt)}
        self.single_observation_space = gymnasium.spaces.Box(-np.inf, np.inf, (self.task.observation_size,), np.float32)
        self.single_action_space = gymnasium.spaces.Box(-1.0, 1.0, (self.task.action_size,), np.float32)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._sums = EpisodeSums.zeros(np, self.task, self.num_envs, np.float64)

    @property
    def nthread(self) -> int:
        """Threads stepping the simulations."""
        return int(self.simulation.physics.nthread)

    def reset(
        self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        """Reset every environment (or those in options["reset_mask"]); `seed` restarts the random stream.

        With `desync_episodes`, each reset environment's episode starts at a uniformly random step in
        [0, episode_length), so that later episodes (full length) end at different steps in each environment.
        """
        if seed is not None:
            self.simulation.seed(seed)
        mask = np.ones(self.num_envs, dtype=bool)
        if options and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"], dtype=bool)
        ids = np.flatnonzero(mask)
        self.simulation.reset(ids)
        if self.desync_episodes:
            self.simulation.episode_step[ids] = self.simulation.random.generator.integers(
                0, self.task.episode_length, len(ids)
            )
        observation = self.task.observe(self.simulation.context()).astype(np.float32)
        self._sums = self._sums.restart(np, mask)
        return observation, {}

    def step(
        self, actions: Any
    ) -> tuple[NDArray[np.float32], NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_], dict[str, Any]]:
        simulation, task = self.simulation, self.task
        failed = simulation.step(actions)
        ctx = simulation.context()
        observation = task.observe(ctx).astype(np.float32)
        outcome = account_step(task, ctx, failed, self._sums, np.float64)
        self._sums = outcome.sums
        simulation.follow_curriculum(outcome.episode.done, outcome.episode.metrics)
        infos: dict[str, Any] = {"reward_terms": outcome.reward_terms, "metrics": outcome.metrics}
        episode = outcome.episode
        if episode.done.any():
            done = episode.done
            infos["final_obs"] = np.where(done[:, None], observation, 0.0).astype(np.float32)
            infos["_final_obs"] = done
            record = {
                "r": np.where(done, episode.return_, 0.0),
                "l": np.where(done, episode.length, 0),
                "failed": episode.failed,
            }
            for name, sums in episode.reward_terms.items():
                record[REWARD_PREFIX + name] = np.where(done, sums, 0.0)
            infos["episode"], infos["_episode"] = record, done
            ids = np.flatnonzero(done)
            observation[ids] = simulation.reset(ids)
        return observation, outcome.reward, outcome.terminated, outcome.truncated, infos

    @property
    def model(self) -> mujoco.MjModel:
        """The model every environment simulates (for drawing them)."""
        return self.simulation.model

    @property
    def qpos(self) -> NDArray[np.float64]:
        """(num_envs, nq) joint positions now, a view of the simulations' state (for drawing them)."""
        return self.simulation.qpos

    def render_frame(
        self,
        env_index: int = 0,
        camera: str | None = None,
        width: int = DEFAULT_RENDER_WIDTH,
        height: int = DEFAULT_RENDER_HEIGHT,
    ) -> NDArray[np.uint8]:
        """(height, width, 3) uint8 image of one environment; `camera` by name (default: the model's first)."""
        return self.simulation.render(env_index, camera, width, height)

    def render(self) -> tuple[NDArray[np.uint8], ...] | None:
        if self.render_mode != "rgb_array":
            return None
        return tuple(self.render_frame(i) for i in range(self.num_envs))

    def close_extras(self, **kwargs: Any) -> None:
        self.simulation.close()


def make_vector_env(
    task: str,
    num_envs: int,
    *,
    seed: int = 0,
    model_path: str | Path | None = None,
    nthread: int | None = None,
    plugins: PluginHost | None = None,
    render_mode: str | None = None,
    **task_options: Any,
) -> BatchedVectorEnv:
    """A BatchedVectorEnv of `num_envs` copies of the registered `task`, reset with `seed`.

    `model_path` replaces the task's model; `nthread` threads step the simulations (default:
    one per core); `plugins` supplies tasks and terms (default: every installed plugin);
    task_options are episode_length, frame_skip, terms={name: {"weight": .., "params": {..}}} or
    task_config (a joshua.TaskConfig).
    """
    spec = EnvSpec(
        task,
        num_envs,
        seed=seed,
        model_path=resolve_data_path(model_path) if model_path else None,
        task_config=task_config_from_options(task_options),
        nthread=nthread,
    )
    return vector_envs(spec, plugins or PluginHost.discover(), render_mode=render_mode)


def vector_env_from_config(training: TrainingConfig, plugins: PluginHost) -> BatchedVectorEnv:
    """The vector env a training config describes: task, model_path (resolved here if relative), num_envs
    (default joshua_core.config.DEFAULT_NUMPY_NUM_ENVS), seed, nthread, task_config."""
    spec = EnvSpec.from_training(training, num_envs=training.num_envs or DEFAULT_NUMPY_NUM_ENVS)
    if spec.model_path is not None:
        spec = dataclasses.replace(spec, model_path=resolve_data_path(spec.model_path))
    return vector_envs(spec, plugins)


def vector_envs(spec: EnvSpec, plugins: PluginHost, *, render_mode: str | None = None) -> BatchedVectorEnv:
    """The BatchedVectorEnv an EnvSpec describes (the `mujoco` backend's EnvKind.NUMPY environments), reset
    with its seed."""
    built, model = load_task_model(spec.task, spec.model_path, plugins, spec.task_config)
    simulation = BatchedSimulation(
        built, model, spec.num_envs, seed=spec.seed, nthread=spec.nthread, curriculum=spec.curriculum
    )
    env = BatchedVectorEnv(simulation, render_mode, desync_episodes=spec.desync_episodes)
    env.reset(seed=spec.seed)
    return env
