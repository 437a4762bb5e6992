"""The small abstract classes plugins implement. Hooks only register these; the work happens here.

- Backend: turns a model file into an Engine (one simulation you can step), and a task into batched
  environments of the kinds it provides (EnvKind, described by an EnvSpec).
- Mode: runs a SimulationConfig (viewer, replay, mirror, offscreen, headless).
- Trainer: runs a TrainingConfig and leaves checkpoints behind.
- Command: a `joshua` subcommand a plugin adds (e.g. `joshua mirror-replay`).
- ModelReader, TrajectoryReader: model files and recorded motion in formats of other tools (USD, LeRobot).
- Term: a task term, a plain function `quantity_kernel(ctx, **params)` returning a batched array.
"""

from __future__ import annotations

import enum
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from joshua_core.errors import ConfigError, UsageError

if TYPE_CHECKING:
    import argparse

    from joshua_core.config_pb2 import SimulationConfig, TaskConfig, TrainingConfig
    from joshua_core.plugins import PluginHost
    from joshua_core.policy import ExportedPolicy
    from joshua_core.run_context import RunContext
    from joshua_core.trajectory import Trajectory

# The size of rendered images when a config leaves simulation.render_width/render_height at 0.
DEFAULT_RENDER_WIDTH = 640
DEFAULT_RENDER_HEIGHT = 480


def render_size(simulation: SimulationConfig) -> tuple[int, int]:
    """(width, height) of the images a simulation config asks for: its render_width/height, else the defaults."""
    return simulation.render_width or DEFAULT_RENDER_WIDTH, simulation.render_height or DEFAULT_RENDER_HEIGHT


class Engine(ABC):
    """One simulation instance: a compiled model (`model`) and its mutable state (`data`)."""

    model: Any
    data: Any

    @property
    @abstractmethod
    def timestep(self) -> float:
        """Seconds of simulated time one `step()` advances."""

    @property
    @abstractmethod
    def time(self) -> float:
        """Current simulated time in seconds."""

    @abstractmethod
    def reset(self, keyframe: str | None = None) -> None:
        """Return to the model's initial state, or to the named keyframe (its qpos, qvel and ctrl)."""

    @abstractmethod
    def step(self, n: int = 1) -> None:
        """Advance the physics by `n` timesteps with the current controls."""

    @abstractmethod
    def set_ctrl(self, values: ArrayLike) -> None:
        """Set all actuator controls; wrong length or non-finite values raise ValueError, changing nothing."""

    @abstractmethod
    def get_qpos(self) -> NDArray[np.float64]:
        """Copy of the generalized positions."""

    @abstractmethod
    def get_sensor(self, name: str) -> NDArray[np.float64]:
        """Copy of one named sensor's reading; an unknown name raises KeyError listing the sensors."""

    @abstractmethod
    def instability(self) -> str | None:
        """Describe numerical instability since the last reset (the physics blew up), or None if there was none."""

    @abstractmethod
    def render(self, camera: str | int | None = None) -> NDArray[np.uint8]:
        """Render the current state headless and return an (H, W, 3) uint8 RGB image."""

    @abstractmethod
    def close(self) -> None:
        """Release rendering and other native resources; the engine may not be used afterwards."""

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


class EnvKind(enum.Enum):
    """The kinds of batched task environments a backend can provide and a trainer can need.

    Both run `num_envs` copies of one task, reset every environment whose episode ended within the
    step that ended it (same-step autoreset), and count episodes as `joshua_core.tasks.episodes` does:
    `terminated` (the task's termination, or a non-finite state: zero reward) and `truncated` (the
    task's episode length reached, only when not terminated). A NaN or infinite action is never clipped into a
    control: a NUMPY environment refuses the step (ValueError), a JAX one, which cannot raise inside a compiled
    step, fails that environment's step as if its state had turned non-finite (`episode.failed`).

    NUMPY: a `gymnasium.vector.VectorEnv` with `metadata["autoreset_mode"] == AutoresetMode.SAME_STEP`,
    float32 Box spaces (actions in [-1, 1]), `num_envs`, `task` (the built `Task`), `render_frame(env_index,
    camera, width, height)`, `model` (the `mujoco.MjModel` simulated) and `qpos` (the (num_envs, nq) joint positions
    now, for drawing) and these infos from `step`: "reward_terms" and "metrics" (name -> (N,)
    arrays of this step); where an episode ended, "final_obs" (valid where "_final_obs") and "episode"
    ("r" return, "l" length, "reward/<term>" the term's episode sum, "failed" whether its simulation blew up;
    valid where "_episode").

    JAX: a functional environment whose methods are pure JAX functions of all environments at once: `reset(key) ->
    state`, `step(state, action) -> state` (jit-compatible, and callable inside `jax.shard_map` on each device's
    slice of the environments) and `redraw_starts(state) -> state` (new start states for the next episodes; called
    between rollouts). `state` is a pytree with the environments on every leaf's leading axis and the fields
    `observation`, `reward`, `terminated`, `truncated`, `final_observation` (the last observation before an
    autoreset), `value_observation` and `final_value_observation` (both without the task's observation noise, for a
    value network; None when the task adds none), `reward_terms`, `commands`, `data.qpos` (for drawing) and
    `episode`, the finished-episode record (`done`, `return_`, `length`, `reward_terms`, `metrics`; valid where
    `done`). Attributes: `num_envs`, `observation_size`, `action_size`, `task` (the built `Task`), `model` (the
    host `mujoco.MjModel`, for rendering), `source` (the model file), `mesh` (a `jax.sharding.Mesh` with one axis,
    of any name, that the environments are spread over), `sharding` (the state's `NamedSharding` over it) and
    `replicated` (the mesh's replicated sharding, for parameters).
    """

    NUMPY = "numpy"
    JAX = "jax"


@dataclass(frozen=True)
class EnvSpec:
    """What batched environments to create: `num_envs` copies of the registered `task`.

    model_path: the model to simulate, already absolute (None: the task's own model, as the backend
    picks it). task_config: overrides of the task's terms and lengths. nthread: threads stepping the
    simulations on CPU backends (None: one per core). devices: the JAX devices to spread over
    (None: every visible one). desync_episodes: each environment's first episode after a reset starts at
    a uniformly random step in [0, episode_length), so that episodes end in every stretch of steps rather
    than all together (training sets it unless `training.synchronized_episodes`). curriculum: the task's
    randomization curriculum (`Task.curriculum`) moves each environment's event strength (training sets it);
    otherwise events act at full strength, as evaluation needs. training: the finalized
    training config the environments are for (None outside one), where a backend reads its own options
    (its extension of TrainingConfig). `num_envs` is checked here, once, for every backend.
    """

    task: str
    num_envs: int
    seed: int = 0
    model_path: Path | None = None
    task_config: TaskConfig | None = None
    nthread: int | None = None
    devices: Sequence[Any] | None = None
    desync_episodes: bool = False
    curriculum: bool = False
    training: TrainingConfig | None = None

    def __post_init__(self) -> None:
        if self.num_envs < 1:
            raise ConfigError(f"num_envs must be at least 1, got {self.num_envs}")

    @classmethod
    def from_training(
        cls, training: TrainingConfig, *, num_envs: int | None = None, seed: int | None = None
    ) -> EnvSpec:
        """The environments a finalized training config describes; `num_envs` and `seed` replace its own."""
        if not training.task:
            raise ConfigError('training.task is empty; name a task, e.g. task: "ant_locomotion" (see `joshua plugins`)')
        return cls(
            task=training.task,
            num_envs=training.num_envs if num_envs is None else num_envs,
            seed=int(training.seed if seed is None else seed),
            model_path=Path(training.model_path) if training.model_path else None,
            task_config=training.task_config if training.HasField("task_config") else None,
            nthread=training.nthread or None,
            training=training,
        )


class Backend(ABC):
    """A physics backend registered under a name (e.g. "mujoco"); creates engines and batched environments.

    The environment kinds a backend provides are declared where it is registered
    (`registry.add(name, target, summary, env_kinds=("numpy",))`), so they are known without importing it.
    """

    @abstractmethod
    def create_engine(
        self,
        model_path: Path,
        plugins: PluginHost,
        *,
        render_width: int = DEFAULT_RENDER_WIDTH,
        render_height: int = DEFAULT_RENDER_HEIGHT,
    ) -> Engine:
        """Load the model at `model_path` (formats other than MJCF through the model readers of `plugins`, the run's
        host); a missing or invalid model raises ModelError."""

    def create_envs(self, spec: EnvSpec, kind: EnvKind, plugins: PluginHost) -> Any:
        """Batched environments of `kind` (see EnvKind) for `spec`, with tasks and terms from `plugins`."""
        raise ConfigError(f"backend {type(self).__name__} provides no {kind.name} environments")

    def model_variant(self, model_path: Path) -> Path:
        """The model file this backend simulates for a task whose model is `model_path`: the file itself, unless the
        backend keeps a variant of its own beside it (mjx: `NAME_mjx.xml`). Asked so that code matching a model file
        to its task (e.g. `joshua_ppo.train_mjx`) knows the variants without importing a backend."""
        return model_path


class Mode(ABC):
    """A simulation mode, registered under the name `simulation.mode` selects (e.g. "OFFSCREEN")."""

    @abstractmethod
    def run(self, config: SimulationConfig, context: RunContext) -> None:
        """Run the simulation until done or interrupted; raise JoshuaError subclasses for user-facing failures."""


class Trainer(ABC):
    """A training algorithm, registered under a name (e.g. "ppo", "sb3")."""

    @abstractmethod
    def train(self, config: TrainingConfig, context: RunContext) -> Path:
        """Train until `config.total_timesteps`; return the folder of the last checkpoint."""

    def evaluate(
        self,
        run_dir: Path,
        *,
        episodes: int,
        seed: int,
        video_path: Path | None,
        context: RunContext,
        trust_checkpoint: bool = False,
        video_grid: int = 1,
    ) -> EpisodeResults:
        """Roll out the policy saved in `run_dir` (a run folder: its last checkpoint; or one checkpoint folder).

        Returns the outcome of each of `episodes` episodes (environments seeded from `seed`): the core computes
        the statistics (joshua_core.statistics), so every trainer reports them alike. When `video_path` is given,
        writes an MP4 of the first `video_grid` episodes tiled in a grid, each tile labelled (the trainer writes
        it itself, e.g. with `joshua_render.GridVideoWriter`: the core renders nothing). `trust_checkpoint`
        allows loading files this machine's user did not write (for formats that can run code on load).
        `joshua eval RUN` calls this.
        """
        raise UsageError(f"trainer {type(self).__name__} cannot evaluate a run: it does not implement evaluate()")

    def export_policy(self, run_dir: Path, *, context: RunContext, trust_checkpoint: bool = False) -> ExportedPolicy:
        """The deterministic policy saved in `run_dir` (a run folder: its last checkpoint; or one checkpoint
        folder) as a framework-free MLP with the run's training config (`joshua_core.policy`), for exporters
        (`joshua export RUN`). A missing or damaged checkpoint is a one-line error; `trust_checkpoint` as in
        `evaluate`."""
        raise UsageError(f"trainer {type(self).__name__} cannot export a policy: it does not implement export_policy()")


@dataclass(frozen=True)
class EpisodeResults:
    """Per-episode outcomes of an evaluation, one entry per episode in each sequence."""

    returns: Sequence[float]  # undiscounted return
    lengths: Sequence[float]  # steps
    metrics: dict[str, Sequence[float]]  # each task metric's value on the episode's last step (e.g. "success")
    failed: Sequence[bool] = ()  # whether each episode's simulation blew up; empty: the trainer does not say


class PolicyFormat(ABC):
    """A format of saved policies that no JOSHUA trainer wrote (e.g. a LeRobot pretrained-policy folder), which
    `joshua eval FOLDER` rolls out in a JOSHUA task. Registered under a format name; importing the class must stay
    light (it is created to declare its options and to ask `accepts`)."""

    @abstractmethod
    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """Declare this format's own `joshua eval` options (named so that they cannot clash with another format's,
        e.g. `--lerobot-python`); given for a folder of another format or a JOSHUA run, they are a usage error."""

    @abstractmethod
    def accepts(self, path: Path) -> bool:
        """Whether the existing folder `path` holds a policy of this format; cheap, loads no policy."""

    @abstractmethod
    def evaluate(
        self,
        path: Path,
        args: argparse.Namespace,
        *,
        episodes: int,
        seed: int,
        video_path: Path | None,
        video_grid: int,
        context: RunContext,
    ) -> EpisodeResults:
        """Roll the policy in `path` out for `episodes` episodes (environments seeded from `seed`), with this
        format's options from `args`; as `Trainer.evaluate`, the outcome of each episode and, when `video_path` is
        given, an MP4 of the first `video_grid` episodes."""


class Command(ABC):
    """A `joshua NAME ...` subcommand registered by a plugin; loaded only when NAME is on the command line."""

    @abstractmethod
    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """Declare the subcommand's arguments on its own parser."""

    def add_plugin_arguments(self, parser: argparse.ArgumentParser, plugins: PluginHost) -> None:
        """Declare the arguments other plugins' registrations bring (`joshua eval`: each policy format's options);
        called after `add_arguments`. Most commands have none."""
        return None

    @abstractmethod
    def run(self, args: argparse.Namespace, plugins: PluginHost) -> int:
        """Do the work and return the exit status; raise JoshuaError subclasses for user-facing failures."""


class ModelReader(ABC):
    """Reads a model file format MuJoCo does not (e.g. USD) into a `mujoco.MjSpec`, registered under the
    file suffix it reads (".usd"); every backend, mode and trainer then takes such files as `model_path`."""

    @abstractmethod
    def read(self, path: Path) -> Any:
        """The `mujoco.MjSpec` of the file at `path` (absolute, existing); a file it cannot read raises ModelError."""


class TrajectoryReader(ABC):
    """Reads recorded motion stored in a format other than JOSHUA's CSV (e.g. a LeRobot dataset folder) into a
    `Trajectory` in the model's units; `joshua_core.trajectory_sources.load_trajectory` dispatches to it, so passive
    replay, validation and every other consumer take the format as `trajectory_path`. Registered under a
    format name; importing the class must stay light (it is created to ask `accepts`)."""

    @abstractmethod
    def accepts(self, path: Path) -> bool:
        """Whether `path` (an existing folder) is in this reader's format; cheap, reads no data."""

    @abstractmethod
    def read(self, path: Path, joints: Mapping[str, tuple[float, float]], *, episode: int = 0) -> Trajectory:
        """Episode `episode` of `path` for a model with the scalar joints `joints` (name -> (low, high) range);
        positions (and targets, when the source has commands) in the model's units. Unreadable data, an unknown
        episode or columns that match no joint raise TrajectoryError."""


class Term(Protocol):
    """A task term: `quantity_kernel(ctx, **params)` returns an array whose leading axis is environments.

    `ctx` exposes the batched simulation state and the array namespace (`ctx.xp`: numpy or jax.numpy),
    so one function runs on CPU and inside `jax.jit`.
    """

    def __call__(self, ctx: Any, **params: Any) -> Any: ...
