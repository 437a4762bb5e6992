"""Trainer `ppo`: a TrainingConfig turned into `train_ppo` on an MJX environment, with run folders,
checkpoints, resume and monitoring (progress bar, TensorBoard, training-curve PNG, rollout MP4s,
the live MuJoCo viewer). The checkpoint layout is in `joshua_ppo.checkpoints`."""

from __future__ import annotations

import sys
import time
from dataclasses import asdict, dataclass
from datetime import datetime
from importlib import metadata
from pathlib import Path
from typing import Any

import jax
import mujoco
import numpy as np
from google.protobuf import json_format

from joshua_core.atomic import atomic_write_json
from joshua_core.config_pb2 import PpoOptions, TrainingConfig
from joshua_core.curves import write_training_curves
from joshua_core.errors import ConfigError, UsageError
from joshua_core.interfaces import RunContext, Trainer
from joshua_core.plugins import PluginHost
from joshua_core.progress import progress_bar
from joshua_mjx.env import MjxEnv, make_mjx_env
from joshua_ppo.checkpoints import (
    CONFIG_FILE,
    METRICS_FILE,
    PARAMS_FILE,
    TRAIN_STATE_FILE,
    checkpoint_dir,
    checkpoint_step,
    read_json,
    read_payload,
    resolve_checkpoint,
    run_checkpoints,
    write_checkpoint,
)
from joshua_ppo.networks import ACTIVATIONS
from joshua_ppo.ppo import (
    IterationReport,
    NetworkSettings,
    OptimizationSettings,
    Progress,
    ReturnSettings,
    RolloutSettings,
    RunningStatistics,
    TrainingState,
    check_settings,
    init_state,
    train_ppo,
)
from joshua_ppo.rollout import collect, make_rollout, mean_results, render_video

TRAINER_NAME = "ppo"
RUN_FORMAT = "joshua-ppo-run/1"
DEFAULT_TOTAL_TIMESTEPS = 50_000_000
CHECKPOINTS_PER_RUN = 10
DEFAULT_VIEWER_ENVS = 4
CURVE_SERIES = ("mean_return", "mean_length", "policy_loss", "value_loss", "entropy", "steps_per_second")


@dataclass(frozen=True)
class PpoSettings:
    """A TrainingConfig's PPO hyper-parameters with the defaults filled in (the product description's numbers)."""

    rollout: RolloutSettings
    optimization: OptimizationSettings
    returns: ReturnSettings
    network: NetworkSettings
    total_timesteps: int
    checkpoint_interval: int
    seed: int

    @classmethod
    def from_config(cls, config: TrainingConfig) -> PpoSettings:
        options = config.ppo
        for name in ("hidden_sizes", "value_hidden_sizes"):
            if any(size <= 0 for size in getattr(options, name)):
                raise ConfigError(f"training.ppo.{name} must be positive, got {list(getattr(options, name))}")
        activation = options.activation or "relu"
        if activation not in ACTIVATIONS:
            raise ConfigError(f"training.ppo.activation '{options.activation}' is not one of: {', '.join(ACTIVATIONS)}")
        if options.desired_kl < 0:
            raise ConfigError(f"training.ppo.desired_kl must not be negative, got {options.desired_kl}")
        for name in ("num_envs", "num_steps", "num_epochs", "minibatch_size", "total_timesteps"):
            if getattr(config, name) < 0:
                raise ConfigError(f"training.{name} must not be negative")
        total = config.total_timesteps or DEFAULT_TOTAL_TIMESTEPS
        max_grad_norm = options.max_grad_norm or 1.0
        return cls(
            rollout=RolloutSettings(
                num_envs=config.num_envs or 2048,
                num_steps=config.num_steps or 10,
                unrolls_per_iteration=options.unrolls_per_iteration or 1,
            ),
            optimization=OptimizationSettings(
                num_epochs=config.num_epochs or 4,
                minibatch_size=config.minibatch_size or 256,
                learning_rate=config.learning_rate or 3e-4,
                clip_epsilon=config.clip_epsilon or 0.2,
                entropy_coef=options.entropy_coef,
                value_coef=options.value_coef or 0.5,
                max_grad_norm=None if max_grad_norm < 0 else max_grad_norm,
                desired_kl=options.desired_kl,
                anneal_steps=total if options.anneal_learning_rate else 0,
            ),
            returns=ReturnSettings(
                gamma=config.gamma or 0.99,
                gae_lambda=config.gae_lambda or 0.95,
                reward_scaling=options.reward_scaling or 1.0,
                recompute_advantages=options.recompute_advantages,
                advantage=PpoOptions.Advantage.Name(options.advantage).lower(),
            ),
            network=NetworkSettings(
                hidden_sizes=tuple(options.hidden_sizes) or (256, 256),
                value_hidden_sizes=tuple(options.value_hidden_sizes),
                normalize_observations=not options.disable_observation_normalization,
                squash_actions=options.squash_actions,
                activation=activation,
                state_dependent_std=options.state_dependent_std,
            ),
            total_timesteps=total,
            checkpoint_interval=options.checkpoint_interval or max(1, total // CHECKPOINTS_PER_RUN),
            seed=int(config.seed),
        )


def environment(
    config: TrainingConfig, plugins: PluginHost | None, num_envs: int, devices: list[jax.Device] | None = None
) -> MjxEnv:
    """The MJX environment of a training config's task, model and task_config, over `devices` (default: all)."""
    if config.backend and config.backend != "mjx":
        raise ConfigError(f"trainer ppo runs on the backend 'mjx', not '{config.backend}'")
    if not config.task:
        raise ConfigError('training.task is empty; name a task, e.g. task: "ant_locomotion" (see `joshua plugins`)')
    return make_mjx_env(
        config.task,
        num_envs,
        model_path=config.model_path or None,
        plugins=plugins,
        task_config=config.task_config if config.HasField("task_config") else None,
        devices=devices,
    )


class ScalarLog:
    """TensorBoard scalars, written with TensorBoard's own event-file writer (no TensorFlow or torch)."""

    def __init__(self, folder: Path) -> None:
        from tensorboard.summary.writer.event_file_writer import EventFileWriter

        self._writer = EventFileWriter(str(folder))

    def write(self, step: int, scalars: dict[str, float]) -> None:
        from tensorboard.compat.proto import event_pb2, summary_pb2

        values = [
            summary_pb2.Summary.Value(tag=name, simple_value=value)
            for name, value in scalars.items()
            if np.isfinite(value)
        ]
        self._writer.add_event(
            event_pb2.Event(wall_time=time.time(), step=step, summary=summary_pb2.Summary(value=values))
        )

    def close(self) -> None:
        self._writer.close()


class LiveViewer:
    """The MuJoCo viewer showing a few training environments, updated after every iteration: the first one
    as the scene, the others drawn into it (on top of each other, where they all start from one place)."""

    def __init__(self, model_path: Path, envs: int) -> None:
        from joshua_modes.display import ViewerDisplay
        from joshua_mujoco import MuJoCoEngine

        self.engine = MuJoCoEngine(model_path)
        self.display = ViewerDisplay(self.engine)
        self.envs = envs
        self._ghost = mujoco.MjData(self.engine.model)
        self._option = mujoco.MjvOption()
        self._perturb = mujoco.MjvPerturb()

    def show(self, qpos: np.ndarray, status: str) -> bool:
        """Show the poses (envs, nq); False once the user closed the window."""
        model = self.engine.model
        with self.display.lock():
            self.engine.data.qpos[:] = qpos[0]
            mujoco.mj_forward(model, self.engine.data)
            scene = self.display.user_scene
            scene.ngeom = 0
            for pose in qpos[1:]:
                self._ghost.qpos[:] = pose
                mujoco.mj_kinematics(model, self._ghost)
                mujoco.mjv_addGeoms(
                    model, self._ghost, self._option, self._perturb, mujoco.mjtCatBit.mjCAT_DYNAMIC, scene
                )
        self.display.set_status(status)
        return self.display.update(self.engine.time)

    def close(self) -> None:
        self.display.close()
        self.engine.close()


def open_viewer(options: PpoOptions, model_path: Path) -> LiveViewer | None:
    """The live viewer the options ask for: AUTO opens it when joshua-modes is installed and a display is usable."""
    if options.viewer == PpoOptions.OFF:
        return None
    try:
        from joshua_modes.display import display_usable, no_display_error
    except ModuleNotFoundError:
        if options.viewer == PpoOptions.ON:
            raise UsageError(
                "training.ppo.viewer ON needs joshua-modes (pip install -e plugins/joshua-modes)"
            ) from None
        return None
    if not display_usable():
        if options.viewer == PpoOptions.ON:
            raise no_display_error("training.ppo.viewer ON (the live MuJoCo viewer)")
        return None
    return LiveViewer(model_path, options.viewer_envs or DEFAULT_VIEWER_ENVS)


class Run:
    """One run being trained: its folder, history and monitors; the callbacks `train_ppo` calls."""

    def __init__(self, config: TrainingConfig, settings: PpoSettings, env: MjxEnv, root: Path, name: str) -> None:
        self.config = config
        self.settings = settings
        self.env = env
        self.root = root
        self.name = name
        self.folder = root / name
        self.history: list[dict[str, float]] = []
        self.last_return = float("nan")
        self.compile_seconds = 0.0
        self.wall_seconds = 0.0
        self.bar: Any = None
        self.scalars: ScalarLog | None = None
        self.viewer: LiveViewer | None = None
        self._rollout: tuple[MjxEnv, Any] | None = None

    def config_document(self) -> dict[str, Any]:
        settings = asdict(self.settings)
        return {
            "trainer": TRAINER_NAME,
            "format": RUN_FORMAT,
            "run": self.name,
            "task": self.config.task,
            "model_path": str(self.config.model_path),
            "seed": self.settings.seed,
            "observation_size": self.env.observation_size,
            "action_size": self.env.action_size,
            "devices": [str(device) for device in jax.devices()],
            "settings": settings,
            "training": json_format.MessageToDict(self.config, preserving_proto_field_name=True),
            "versions": {
                name: _version(name) for name in ("joshua-ppo", "jax", "flax", "optax", "mujoco", "mujoco-mjx")
            },
        }

    def metrics_document(self, progress: Progress) -> dict[str, Any]:
        recent = self.history[-1] if self.history else {}
        return {
            "env_steps": progress.env_steps,
            "iteration": progress.iteration,
            "wall_seconds": round(self.wall_seconds, 3),
            "compile_seconds": round(self.compile_seconds, 3),
            "steps_per_second": recent.get("steps_per_second", 0.0),
            "mean_return": self.last_return,
            "history": [record for record in self.history if record["step"] <= progress.env_steps],
        }

    # --- callbacks of train_ppo ---

    def on_progress(self, report: IterationReport, state: TrainingState) -> None:
        metrics = report.metrics
        if metrics["episodes"] > 0:
            self.last_return = metrics["mean_return"]
        self.compile_seconds, self.wall_seconds = report.compile_seconds, report.wall_seconds
        record = {"step": report.env_steps, "steps_per_second": round(report.steps_per_second, 1)}
        record |= {name: value for name, value in metrics.items() if np.isfinite(value)}
        self.history.append(record)
        if self.scalars is not None:
            self.scalars.write(report.env_steps, {**metrics, "steps_per_second": report.steps_per_second})
        self.bar.set_description_str(f"ppo {self.config.task} return {self.last_return:.4g}", refresh=False)
        self.bar.update(report.env_steps - self.bar.n)
        interval = self.config.ppo.video_interval
        if interval > 0 and report.iteration % interval == 0:
            self.record_video(state, report.env_steps)
        if self.viewer is not None:
            qpos = np.asarray(jax.device_get(state.env_state.data.qpos[: self.viewer.envs]))
            status = f"step {report.env_steps:,}  return {self.last_return:.4g}  {report.steps_per_second:,.0f} steps/s"
            if not self.viewer.show(qpos, status):
                self.viewer.close()
                self.viewer = None

    def on_checkpoint(self, state: TrainingState, progress: Progress, report: IterationReport | None) -> None:
        params = {"params": state.params, "normalizer": state.normalizer._asdict()}
        train_state = {
            "opt_state": state.opt_state,
            "key": state.key,
            "iteration": progress.iteration,
            "env_steps": progress.env_steps,
        }
        metrics = self.metrics_document(progress)
        folder = checkpoint_dir(self.root, self.name, progress.env_steps)
        documents = {CONFIG_FILE: self.config_document(), METRICS_FILE: metrics}
        write_checkpoint(
            folder, {PARAMS_FILE: jax.device_get(params), TRAIN_STATE_FILE: jax.device_get(train_state)}, documents
        )
        atomic_write_json(self.folder / METRICS_FILE, metrics)
        write_training_curves(
            self.history, self.folder / "training_curves.png", title=f"{self.config.task}: ppo", series=CURVE_SERIES
        )
        if report is not None and self.config.ppo.video_interval == 0:
            self.record_video(state, progress.env_steps)

    def record_video(self, state: TrainingState, step: int) -> None:
        """Roll out the current deterministic policy for one episode and render it to videos/step_<N>.mp4."""
        if self._rollout is None:
            env = environment(self.config, None, len(jax.devices()))
            steps = self.config.ppo.video_steps or env.task.episode_length
            self._rollout = env, make_rollout(env, self.settings.network, steps)
        env, rollout = self._rollout
        episode = collect(rollout(state.params, state.normalizer, jax.random.PRNGKey(step)))
        path = render_video(env.model, episode, self.folder / "videos" / f"step_{step}.mp4", fps=1.0 / env.task.dt)
        if path is not None:
            self.bar.write(f"ppo: video {path}")


def _version(distribution: str) -> str:
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return "unknown"


def _run_name(config: TrainingConfig, root: Path) -> tuple[str, Path | None]:
    """The run's name and the checkpoint to resume from (None for a new run)."""
    options = config.ppo
    if options.resume:
        name = options.run_name or _newest_run(root)
        checkpoints = run_checkpoints(root, name)
        if not (root / name / CONFIG_FILE).is_file() or not checkpoints:
            raise ConfigError(f"training.ppo.resume: there is no run '{name}' with a checkpoint in {root} to resume")
        saved = read_json(root / name / CONFIG_FILE)
        if saved.get("task") != config.task:
            raise ConfigError(
                f"training.ppo.resume: run '{name}' trained task '{saved.get('task')}', "
                f"this config asks for '{config.task}'"
            )
        return name, checkpoints[-1]
    name = options.run_name or f"{config.task}_{datetime.now():%Y%m%d-%H%M%S}"
    if (root / name).exists() or run_checkpoints(root, name):
        raise ConfigError(
            f"run '{name}' exists in {root}; continue it with --set training.ppo.resume=true, "
            "or choose another training.ppo.run_name"
        )
    return name, None


def _newest_run(root: Path) -> str:
    runs = [path.parent for path in root.glob(f"*/{CONFIG_FILE}") if read_json(path).get("trainer") == TRAINER_NAME]
    if not runs:
        raise ConfigError(f"training.ppo.resume: {root} has no ppo run to resume")
    return max(runs, key=lambda path: (path / CONFIG_FILE).stat().st_mtime).name


def load_params(checkpoint: Path, env: MjxEnv, network: NetworkSettings) -> tuple[Any, RunningStatistics]:
    """A checkpoint's network parameters and observation normaliser, checked against the network's shapes."""
    template = init_state(env, seed=0, network=network, optimization=OptimizationSettings())
    saved = read_payload(
        checkpoint, PARAMS_FILE, {"params": template.params, "normalizer": template.normalizer._asdict()}
    )
    return saved["params"], RunningStatistics(**saved["normalizer"])


def load_state(checkpoint: Path, env: MjxEnv, settings: PpoSettings) -> tuple[TrainingState, Progress]:
    """The full training state of a checkpoint (environments freshly reset), for resuming."""
    template = init_state(env, seed=settings.seed, network=settings.network, optimization=settings.optimization)
    params, normalizer = load_params(checkpoint, env, settings.network)
    target = {"opt_state": template.opt_state, "key": template.key, "iteration": 0, "env_steps": 0}
    saved = read_payload(checkpoint, TRAIN_STATE_FILE, target)
    state = TrainingState(
        params, saved["opt_state"], normalizer, env.reset(jax.random.fold_in(saved["key"], 1)), saved["key"]
    )
    state = jax.device_put(state, jax.tree.map(lambda leaf: leaf.sharding, template))
    return state, Progress(int(saved["iteration"]), int(saved["env_steps"]))


class PpoTrainer(Trainer):
    """PPO on MJX; see the plugin README."""

    def train(self, config: TrainingConfig, context: RunContext) -> Path:
        settings = PpoSettings.from_config(config)
        env = environment(config, context.plugins, settings.rollout.num_envs)
        # a bad batch layout is a config error before anything is written
        check_settings(
            settings.rollout, settings.optimization, env.mesh.size, whole_unrolls=settings.returns.recompute_advantages
        )
        root = context.output_dir
        name, resume_from = _run_name(config, root)
        run = Run(config, settings, env, root, name)
        resume = None
        if resume_from is not None:
            resume = load_state(resume_from, env, settings)
            previous = read_json(resume_from / METRICS_FILE)
            run.history = [record for record in previous.get("history", []) if record["step"] <= resume[1].env_steps]
            run.last_return = float(previous.get("mean_return", float("nan")))
            print(f"ppo: resuming {name} from {resume_from.name} ({resume[1].env_steps} steps)")
        else:
            run.folder.mkdir(parents=True, exist_ok=True)
            atomic_write_json(run.folder / CONFIG_FILE, run.config_document())
        start = resume[1].env_steps if resume else 0
        run.bar = progress_bar(settings.total_timesteps, description=f"ppo {config.task}", unit="steps", initial=start)
        run.scalars = ScalarLog(run.folder / "tensorboard")
        run.viewer = open_viewer(config.ppo, env.source)
        devices = ", ".join(str(device) for device in jax.devices())
        run.bar.write(f"ppo: {settings.rollout.num_envs} environments on {devices}; compiling the training iteration")
        try:
            _, progress = train_ppo(
                env,
                rollout=settings.rollout,
                optimization=settings.optimization,
                returns=settings.returns,
                network=settings.network,
                total_timesteps=settings.total_timesteps,
                seed=settings.seed,
                checkpoint_interval=settings.checkpoint_interval,
                resume=resume,
                on_progress=run.on_progress,
                on_checkpoint=run.on_checkpoint,
            )
        finally:
            run.bar.close()
            run.scalars.close()
            if run.viewer is not None:
                run.viewer.close()
        checkpoint = run_checkpoints(root, name)[-1]
        print(
            f"ppo: {progress.env_steps} steps in {run.wall_seconds:.1f} s (compile {run.compile_seconds:.1f} s), "
            f"mean return {run.last_return:.4g}; checkpoint {checkpoint}"
        )
        return checkpoint

    def evaluate(
        self,
        run_dir: Path,
        *,
        episodes: int,
        seed: int,
        video_path: Path | None,
        context: RunContext,
        trust_checkpoint: bool = False,
    ) -> dict[str, float]:
        checkpoint = resolve_checkpoint(run_dir)
        saved = read_json(checkpoint / CONFIG_FILE)
        if saved.get("format") != RUN_FORMAT:
            raise UsageError(f"{checkpoint / CONFIG_FILE} is not a {RUN_FORMAT} run config")
        config = TrainingConfig()
        try:
            json_format.ParseDict(saved["training"], config)
        except (KeyError, json_format.ParseError) as error:
            raise UsageError(f"{checkpoint / CONFIG_FILE}: unreadable training config: {error}") from None
        settings = PpoSettings.from_config(config)
        devices = len(jax.devices())
        env = environment(config, context.plugins, -(-episodes // devices) * devices)
        params, normalizer = load_params(checkpoint, env, settings.network)
        print(f"ppo: evaluating {checkpoint} ({checkpoint_step(checkpoint)} steps) over {episodes} episodes")
        rollout = make_rollout(env, settings.network, env.task.episode_length)
        episode = collect(rollout(params, normalizer, jax.random.PRNGKey(seed)), episodes)
        if video_path is not None:
            written = render_video(env.model, episode, video_path, fps=1.0 / env.task.dt)
            if written is not None:
                print(f"video: {written}", file=sys.stderr)
        return mean_results(episode)
