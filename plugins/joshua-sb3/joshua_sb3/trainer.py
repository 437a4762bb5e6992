"""Trainer `sb3`: stable-baselines3 PPO, SAC or TD3 on the NUMPY environments (EnvKind.NUMPY) of a task, from
the backend the config names (`mujoco`, or any other that provides them).

The run folder layout and the checkpoint trust rules are in `joshua_sb3.run_folder`.
"""

from __future__ import annotations

import sys
import time
from importlib import metadata
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
import torch
from stable_baselines3 import PPO, SAC, TD3
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.logger import KVWriter, Logger, TensorBoardOutputFormat
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

from joshua_core.atomic import atomic_write_json
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.defaults import DEFAULT_NUMPY_NUM_ENVS
from joshua_core.determinism import use_determinism
from joshua_core.errors import ConfigError, CorruptCheckpointError, TrainingDiverged, UsageError
from joshua_core.interfaces import EnvKind, EpisodeResults, Trainer
from joshua_core.interrupts import StopRequest, resume_command, stop_requests
from joshua_core.json_files import read_json_object
from joshua_core.options import message_to_dict
from joshua_core.policy import ExportedPolicy
from joshua_core.progress import progress_bar
from joshua_core.run_context import RunContext
from joshua_core.runs import (
    CONFIG_FILE,
    METRICS_FILE,
    RunFolder,
    check_run_name,
    checkpoint_step,
    create_run,
    resolve_checkpoint,
    resume_run,
    saved_training,
)
from joshua_core.tasks import FAILED_EPISODES, METRIC_PREFIX, MIN_ENDED_EPISODES, REWARD_PREFIX, check_blow_ups
from joshua_sb3.export import saved_policy
from joshua_sb3.rollout import roll_out
from joshua_sb3.run_folder import (
    MODEL_FILE,
    NORMALIZATION_FILE,
    REPLAY_BUFFER_FILE,
    update_run_metrics,
    verify_checkpoint,
    write_checkpoint,
)
from joshua_sb3.settings import OPTION, Settings
from joshua_sb3.vec_env import METRICS_KEY, REWARD_TERMS_KEY, SameStepVecEnv, blown_up, ended_episodes
from joshua_sb3.web_page import PagePublisher, open_page

TRAINER_NAME = "sb3"
RUN_FORMAT = "joshua-sb3-run/1"
ALGORITHM_CLASSES: dict[str, type[BaseAlgorithm]] = {"PPO": PPO, "SAC": SAC, "TD3": TD3}
DEVICE = "cpu"  # small MLP policies: the CPU beats a GPU round trip per environment step
RUN_OPTIONS = "training"  # where the run options (run_name, resume) live, for hints
TRAIN_TRUST_HINT = "--set training.sb3.trust_checkpoint=true"
EVAL_TRUST_HINT = "joshua eval RUN --trust-checkpoint"


def make_vec_env(
    training: TrainingConfig, context: RunContext, *, training_envs: bool = False
) -> tuple[gymnasium.vector.VectorEnv, VecEnv]:
    """The task's NUMPY environments from the backend the config names, and the SB3 view of them (without
    normalisation); `training_envs`: the ones SB3 learns on (desynchronised episodes)."""
    environments = context.create_envs(training, EnvKind.NUMPY, training_envs=training_envs)
    return environments, SameStepVecEnv(environments)


class MetricsHistory(KVWriter):
    """Keeps every record SB3's logger dumps (one per iteration), for metrics.json and the progress bar."""

    def __init__(self, records: list[dict[str, Any]]) -> None:
        self.records = records

    def write(self, key_values: dict[str, Any], key_excluded: dict[str, Any], step: int = 0) -> None:
        record: dict[str, Any] = {"step": int(step)}
        for name, value in key_values.items():
            if isinstance(value, int | float | np.number):
                record[name] = float(value)
        self.records.append(record)


class TrainingMonitor(BaseCallback):
    """Progress bar, per-term reward and task-metric logging, blow-ups counted (and stopped where they are most of
    the episodes, as the JAX trainers do: `check_blow_ups`), and periodic checkpoints."""

    def __init__(self, run: RunWriter, bar: Any, next_checkpoint: int, stop: StopRequest) -> None:
        super().__init__()
        self.run = run
        self.stop = stop
        self.bar = bar
        self.next_checkpoint = next_checkpoint
        self.failed = 0  # episodes of this rollout that blew up
        self.logged_failed = 0  # of the rollouts since the logger last wrote its values
        self.stretch = (0, 0, run.start_step)  # episodes ended, of them blown up, since the step: for check_blow_ups

    def _on_step(self) -> bool:
        self.bar.update(self.model.num_timesteps - self.bar.n)
        ended = ended_episodes(self.locals["infos"], self.locals["dones"])
        failed = blown_up(ended)
        self.failed += failed
        self.stretch = (self.stretch[0] + len(ended), self.stretch[1] + failed, self.stretch[2])
        return not self.stop.requested  # SB3 ends learn() cleanly: the checkpoint after it is consistent

    def _on_rollout_start(self) -> None:
        # Here the previous rollout has been learned from: a consistent point to save.
        if self.model.num_timesteps >= self.next_checkpoint:
            self.run.save_checkpoint(self.model)
            while self.next_checkpoint <= self.model.num_timesteps:
                self.next_checkpoint += self.run.settings.checkpoint_interval

    def _on_rollout_end(self) -> None:
        if FAILED_EPISODES not in self.logger.name_to_value:  # the logger wrote its values since: count afresh
            self.logged_failed = 0
        self.logged_failed += self.failed
        self.failed = 0
        self.logger.record(FAILED_EPISODES, self.logged_failed)
        ended, failed, since = self.stretch
        if ended >= MIN_ENDED_EPISODES:  # before learning from a batch of blow-ups
            check_blow_ups(ended, failed, f"steps {since} to {self.model.num_timesteps}")
            self.stretch = (0, 0, self.model.num_timesteps)
        episodes = list(self.model.ep_info_buffer or [])
        if not episodes:
            return
        for key, prefix in ((REWARD_TERMS_KEY, REWARD_PREFIX), (METRICS_KEY, METRIC_PREFIX)):
            for name in episodes[-1].get(key, {}):
                values = [episode[key][name] for episode in episodes if name in episode.get(key, {})]
                self.logger.record(prefix + name, float(np.mean(values)))
        mean_return = float(np.mean([episode["r"] for episode in episodes]))
        self.bar.set_description_str(f"sb3 {self.run.settings.algorithm} return {mean_return:.3g}", refresh=False)


class RunWriter:
    """One run folder being trained: its settings, environments and the history of logged metrics."""

    def __init__(self, run: RunFolder, config: TrainingConfig, settings: Settings, normalizer: VecNormalize | None):
        self.run = run
        self.run_dir = run.path
        self.config = config
        self.settings = settings
        self.normalizer = normalizer
        self.records: list[dict[str, Any]] = []
        self.started = time.perf_counter()
        self.start_step = 0

    def config_document(self) -> dict[str, Any]:
        return {
            "trainer": TRAINER_NAME,
            "format": RUN_FORMAT,
            "algorithm": self.settings.algorithm,
            "task": self.config.task,
            "settings": self.settings.as_dict(),
            "training": message_to_dict(self.config),
            "versions": {name: _version(name) for name in ("joshua-sb3", "stable-baselines3", "torch", "mujoco")},
        }

    def metrics_document(self, step: int) -> dict[str, Any]:
        elapsed = time.perf_counter() - self.started
        history = [record for record in self.records if record["step"] <= step]
        return {
            "num_timesteps": step,
            "wall_seconds": round(elapsed, 3),
            "steps_per_second": round((step - self.start_step) / elapsed, 1) if elapsed > 0 else 0.0,
            FAILED_EPISODES: int(sum(record.get(FAILED_EPISODES, 0) for record in history)),
            "history": history,
        }

    def save_checkpoint(self, model: BaseAlgorithm) -> Path:
        """Write a checkpoint of `model`; a policy that is no longer finite is TrainingDiverged, never saved."""
        step = int(model.num_timesteps)
        if not _finite_policy(model):
            raise _diverged(step)

        def save(folder: Path) -> None:
            model.save(folder / MODEL_FILE)
            if self.normalizer is not None:
                self.normalizer.save(str(folder / NORMALIZATION_FILE))
            if isinstance(model, OffPolicyAlgorithm):
                model.save_replay_buffer(folder / REPLAY_BUFFER_FILE)

        metrics = self.metrics_document(step)
        documents = {CONFIG_FILE: self.config_document(), METRICS_FILE: metrics}
        checkpoint = write_checkpoint(self.run, step, save, documents, keep_replay_buffer=False)
        update_run_metrics(self.run_dir, metrics, title=f"{self.config.task}: sb3 {self.settings.algorithm}")
        return checkpoint


def _finite_policy(model: BaseAlgorithm) -> bool:
    """Whether every parameter of the model's policy (and critics) is finite."""
    return all(bool(torch.isfinite(parameter).all()) for parameter in model.policy.parameters())


def _refused_by_distribution(error: ValueError) -> bool:
    """Whether `error` is torch.distributions refusing the policy's outputs (a NaN mean, a zero standard deviation
    from a log-std driven to -1e30): the policy diverged, though its parameters may still be finite numbers."""
    frame = error.__traceback__
    while frame is not None and frame.tb_next is not None:
        frame = frame.tb_next
    return frame is not None and str(frame.tb_frame.f_globals.get("__name__", "")).startswith("torch.distributions")


def _diverged(step: int) -> TrainingDiverged:
    """The one-line error of a training whose policy diverged at `step`, with what to try."""
    return TrainingDiverged(
        f"training diverged at {step} steps: the policy's parameters became NaN or infinite, or too large for its "
        "action distribution; the last checkpoint written before it is kept. Lower training.learning_rate, keep "
        f"the observations normalised (no {RUN_OPTIONS}.disable_normalization), or check the model and the task's "
        "rewards and observations for huge values"
    )


def _version(distribution: str) -> str:
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return "unknown"


def _open_run(config: TrainingConfig, context: RunContext, settings: Settings) -> tuple[RunFolder, Path | None]:
    """The run folder to write, locked, and the checkpoint to resume from (None for a new run, or for a
    resumed run killed before its first checkpoint)."""
    root = context.output_dir
    if settings.run_name:
        check_run_name(settings.run_name, f"{RUN_OPTIONS}.run_name")
    if not settings.resume:
        stem = f"{config.task}_{settings.algorithm.lower()}"
        return create_run(root, settings.run_name or None, stem=stem, options=RUN_OPTIONS), None
    run, saved = resume_run(root, settings.run_name or None, trainer=TRAINER_NAME, options=RUN_OPTIONS)
    for key, value in (("algorithm", settings.algorithm), ("task", config.task)):
        if saved.get(key) != value:
            run.close()
            raise ConfigError(
                f"{RUN_OPTIONS}.resume: run {run.path} was trained with {key} '{saved.get(key)}', "
                f"this config asks for '{value}'"
            )
    checkpoints = run.checkpoints()
    if not checkpoints:
        print(
            f"joshua: warning: {RUN_OPTIONS}.resume: run {run.path} has no checkpoint (it stopped before its first); "
            "training it from the start",
            file=sys.stderr,
        )
    return run, checkpoints[-1] if checkpoints else None


def _load_model(
    checkpoint: Path, algorithm: str, vec_env: VecEnv, *, trust: bool, trust_hint: str, with_buffer: bool
) -> tuple[BaseAlgorithm, VecNormalize | None]:
    """Load a checkpoint's model (and normalisation statistics) after checking it may be unpickled."""
    has_normalizer = (checkpoint / NORMALIZATION_FILE).is_file()
    has_buffer = with_buffer and (checkpoint / REPLAY_BUFFER_FILE).is_file()
    names = [MODEL_FILE] + [NORMALIZATION_FILE] * has_normalizer + [REPLAY_BUFFER_FILE] * has_buffer
    verify_checkpoint(checkpoint, names, trust=trust, trust_hint=trust_hint)
    try:
        normalizer = VecNormalize.load(str(checkpoint / NORMALIZATION_FILE), vec_env) if has_normalizer else None
        model = ALGORITHM_CLASSES[algorithm].load(checkpoint / MODEL_FILE, env=normalizer or vec_env, device=DEVICE)
        if has_buffer and isinstance(model, OffPolicyAlgorithm):
            model.load_replay_buffer(checkpoint / REPLAY_BUFFER_FILE)
    except Exception as error:  # a corrupt or foreign file can fail in any way inside SB3 or pickle
        message = f"cannot load checkpoint '{checkpoint}': {type(error).__name__}: {error}"
        raise CorruptCheckpointError(message) from None
    return model, normalizer


class Sb3Trainer(Trainer):
    """stable-baselines3 on the NUMPY environments of the configured backend; see the plugin README."""

    def train(self, config: TrainingConfig, context: RunContext) -> Path:
        if use_determinism(config):  # the JAX environments' XLA flag, and torch's deterministic algorithms
            torch.use_deterministic_algorithms(True)
        settings: Settings = context.settings(OPTION, config)
        folder, resume_from = _open_run(config, context, settings)
        with folder:  # locked while training; a new run that fails before writing anything leaves no folder
            return self._train(config, context, settings, folder, resume_from)

    def _train(
        self,
        config: TrainingConfig,
        context: RunContext,
        settings: Settings,
        folder: RunFolder,
        resume_from: Path | None,
    ) -> Path:
        run_dir = folder.path
        training = TrainingConfig()
        training.CopyFrom(config)
        training.num_envs = config.num_envs or DEFAULT_NUMPY_NUM_ENVS  # the environments hold the number
        environments, vec_env = make_vec_env(training, context, training_envs=True)
        if resume_from is not None:
            model, normalizer = _load_model(
                resume_from,
                settings.algorithm,
                vec_env,
                trust=settings.trust_checkpoint,
                trust_hint=TRAIN_TRUST_HINT,
                with_buffer=True,
            )
            model.set_random_seed(settings.seed + model.num_timesteps)  # not the same noise as the first leg
            print(f"sb3: resuming {run_dir} from {resume_from.name} ({model.num_timesteps} steps)")
        else:
            normalizer = VecNormalize(vec_env, gamma=settings.gamma) if settings.normalize else None
            model = ALGORITHM_CLASSES[settings.algorithm](
                "MlpPolicy", normalizer or vec_env, seed=settings.seed, device=DEVICE, **settings.algorithm_kwargs()
            )
        run = RunWriter(folder, training, settings, normalizer)
        if resume_from is None:  # also a resumed run killed before its first checkpoint: its config is rewritten
            atomic_write_json(run_dir / CONFIG_FILE, run.config_document())
        else:
            metrics = run_dir / METRICS_FILE
            previous = (
                read_json_object(metrics, "the run's metrics", CorruptCheckpointError) if metrics.is_file() else {}
            )
            run.records = [r for r in previous.get("history", []) if r["step"] <= model.num_timesteps]
        run.start_step = int(model.num_timesteps)
        model.set_logger(
            Logger(str(run_dir), [TensorBoardOutputFormat(str(run_dir / "tensorboard")), MetricsHistory(run.records)])
        )
        page = open_page(config, environments, title=f"JOSHUA {config.task}: sb3 {settings.algorithm}")
        bar = progress_bar(
            settings.total_timesteps, description=f"sb3 {settings.algorithm}", unit="steps", initial=run.start_step
        )
        try:
            extra = [PagePublisher(page, environments)] if page is not None else []
            checkpoint = _learn(run, model, bar, first_leg=resume_from is None, extra_callbacks=extra)
        finally:
            bar.close()
            if page is not None:
                page.close()
            environments.close()
        failed = run.metrics_document(int(model.num_timesteps))[FAILED_EPISODES]
        blown = f"; {failed} episodes blew up" if failed else ""
        print(f"sb3: {model.num_timesteps} steps{blown}; checkpoint {checkpoint}")
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
        video_grid: int = 1,
    ) -> EpisodeResults:
        checkpoint, saved, training = saved_training(run_dir, RUN_FORMAT, context.plugins.options())
        training.num_envs = episodes
        training.seed = seed
        environments, vec_env = make_vec_env(training, context)
        try:
            model, normalizer = _load_model(
                checkpoint,
                saved["algorithm"],
                vec_env,
                trust=trust_checkpoint,
                trust_hint=EVAL_TRUST_HINT,
                with_buffer=False,
            )
            if normalizer is not None:
                normalizer.training = False
                normalizer.norm_reward = False
            print(f"sb3: evaluating {checkpoint} ({checkpoint_step(checkpoint)} steps) over {episodes} episodes")
            return roll_out(model, normalizer or vec_env, environments, video_path, video_grid)
        finally:
            environments.close()

    def export_policy(self, run_dir: Path, *, context: RunContext, trust_checkpoint: bool = False) -> ExportedPolicy:
        checkpoint, saved, training = saved_training(run_dir, RUN_FORMAT, context.plugins.options())
        algorithm = saved.get("algorithm")
        if algorithm not in ALGORITHM_CLASSES:
            raise UsageError(f"{checkpoint / CONFIG_FILE}: unknown algorithm {algorithm!r}")
        policy = saved_policy(checkpoint, ALGORITHM_CLASSES[algorithm], trust=trust_checkpoint, device=DEVICE)
        return ExportedPolicy(TRAINER_NAME, checkpoint, training, policy)


def _learn(
    run: RunWriter, model: BaseAlgorithm, bar: Any, *, first_leg: bool, extra_callbacks: list[BaseCallback]
) -> Path:
    """Train up to the total, saving checkpoints, calling `extra_callbacks` too; the last checkpoint is returned.
    A SIGINT or SIGTERM stops training at the next environment step: a checkpoint is saved, the command that
    resumes is printed and `Interrupted` raised (the CLI exits 130 or 143)."""
    with stop_requests() as stop:
        if first_leg:
            run.save_checkpoint(model)  # step 0: the untrained policy, to compare against
        print(f"sb3: training {run.run_dir}; Ctrl-C saves a checkpoint and stops", flush=True)
        remaining = run.settings.total_timesteps - model.num_timesteps
        if remaining <= 0:
            return resolve_checkpoint(run.run_dir)
        monitor = TrainingMonitor(run, bar, run.start_step + run.settings.checkpoint_interval, stop)
        try:
            model.learn(
                remaining,
                callback=CallbackList([monitor, *extra_callbacks]),
                reset_num_timesteps=False,
                progress_bar=False,
            )
        except ValueError as error:
            if _finite_policy(model) and not _refused_by_distribution(error):
                raise
            raise _diverged(int(model.num_timesteps)) from None
        checkpoint = run.save_checkpoint(model)
        if stop.requested:
            print(
                f"sb3: stopped at {model.num_timesteps} steps; checkpoint {checkpoint}\n"
                f"resume with: {resume_command(RUN_OPTIONS, run.run.name)}",
                flush=True,
            )
            raise stop.interrupted()
    return checkpoint
