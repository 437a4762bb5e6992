"""Trainer `ppo`: a TrainingConfig turned into `train_ppo` on JAX environments (EnvKind.JAX, from the backend
the config names: `mjx`, or another that provides them), with run folders,
checkpoints, resume and monitoring (`joshua_ppo.run`), and the evaluation of a saved run."""

from __future__ import annotations

import sys
from abc import ABC, abstractmethod
from collections.abc import Callable
from pathlib import Path
from typing import Any

import jax

from joshua_core.atomic import atomic_write_json
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.determinism import use_determinism
from joshua_core.errors import ConfigError
from joshua_core.interfaces import EpisodeResults, Trainer
from joshua_core.interrupts import resume_command, stop_requests
from joshua_core.limits import check_one_iteration
from joshua_core.policy import ExportedPolicy
from joshua_core.run_context import RunContext
from joshua_core.runs import (
    CONFIG_FILE,
    RunFolder,
    check_run_name,
    checkpoint_step,
    create_run,
    resume_run,
    saved_training,
)
from joshua_jax import CompileCache, use_compile_cache
from joshua_ppo.checkpoints import RESUME_FILES, RUN_FORMAT, load_params, load_state, resume_payloads
from joshua_ppo.config_settings import OPTION, PpoSettings
from joshua_ppo.distributed import Cluster, join
from joshua_ppo.envs import JaxEnv, environment
from joshua_ppo.export import mlp_policy
from joshua_ppo.normalizer import RunningStatistics
from joshua_ppo.policy import deterministic_policy
from joshua_ppo.rollout import Act, collect, episode_results, make_rollout, render_video
from joshua_ppo.run import TRAINER_NAME, PpoRun, Run
from joshua_ppo.settings import NetworkSettings, RunSettings, check_settings
from joshua_ppo.state import Progress
from joshua_ppo.teacher import load_teacher
from joshua_ppo.train import train_ppo

RUN_OPTIONS = "training"  # where the run options (run_name, resume) live, for hints
Resume = tuple[Path, dict[str, bytes]]  # the checkpoint to resume from and its payloads (resume_payloads)
# a trainer's loop given its keyword arguments resume, on_progress, on_checkpoint and should_stop -> where it ended
Fit = Callable[..., Progress]
SavedPolicy = tuple[Act, Any, RunningStatistics]  # a checkpoint's policy, its parameters and normaliser
Load = Callable[[Path, dict[str, bytes]], tuple[Any, Progress]]  # (checkpoint, its payloads) -> state to resume


class JaxTrainer(Trainer, ABC):
    """What every trainer of this distribution does around its algorithm: the run folder (new or resumed, process
    0's), the processes of a multi-process run, monitors, and stopping on a signal with a checkpoint."""

    name: str  # the registered trainer name, written into config.json
    run_format: str  # the "format" of its runs' config.json
    option: str  # the option whose settings it trains with (`RunContext.settings`)

    def prepare(self, config: TrainingConfig, run: RunSettings) -> tuple[CompileCache, Cluster]:
        """What comes before anything compiles or is built: the determinism flags (before JAX starts its backends),
        the compilation cache, the run's processes (before anything asks JAX for its devices), and the run name
        checked."""
        use_determinism(config)
        cache = use_compile_cache()
        cluster = join(config)
        cluster.check_same_config(config)
        if run.name:
            check_run_name(run.name, f"{RUN_OPTIONS}.run_name")
        return cache, cluster

    def open_run(
        self, config: TrainingConfig, settings: RunSettings, root: Path, processes: int
    ) -> tuple[RunFolder, Resume | None]:
        """The run folder, locked, and the checkpoint to resume from with what resuming reads (None: a new run)."""
        if not settings.resume:
            return create_run(root, settings.name or None, stem=config.task, options=RUN_OPTIONS), None
        run, saved = resume_run(root, settings.name or None, trainer=self.name, options=RUN_OPTIONS)
        try:
            if saved.get("task") != config.task:
                raise ConfigError(
                    f"{RUN_OPTIONS}.resume: run '{run.name}' trained task '{saved.get('task')}', "
                    f"this config asks for '{config.task}'"
                )
            if saved.get("processes", 1) != processes:
                raise ConfigError(
                    f"{RUN_OPTIONS}.resume: run '{run.name}' was trained by {saved.get('processes', 1)} "
                    f"processes, this one has {processes}; resume it with as many (the environments are split across "
                    "them)"
                )
            checkpoints = run.checkpoints()
            if not checkpoints:
                raise ConfigError(f"{RUN_OPTIONS}.resume: run '{run.name}' in {root} has no checkpoint to resume from")
            return run, (checkpoints[-1], resume_payloads(checkpoints[-1]))
        except Exception:
            run.close()
            raise

    def train_run(
        self,
        config: TrainingConfig,
        context: RunContext,
        cluster: Cluster,
        settings: RunSettings,
        make_run: Callable[[RunFolder], Run],
        load: Load,
        fit: Fit,
    ) -> Path:
        """Open the run on process 0 (`make_run` its monitors), resume it or write its config, and `fit` on every
        process; a signal stops it after an iteration, with a checkpoint and the command that resumes it."""
        opened = cluster.on_leader(lambda: self.open_run(config, settings, context.output_dir, cluster.num_processes))
        if opened is None:  # another process than 0: it trains alongside and writes nothing
            return self._train(cluster, None, _shared_resume(cluster, None), load, fit)
        folder, resume = opened
        with folder:  # locked while training
            return self._train(cluster, make_run(folder), _shared_resume(cluster, resume), load, fit)

    def _train(self, cluster: Cluster, run: Run | None, resume: Resume | None, load: Load, fit: Fit) -> Path:
        """Train on every process; `run` (process 0's, None on the others) records and reports."""
        state = None
        if resume is not None:
            state = load(*resume)
            if run is not None:
                run.resumed_from(resume[0], state[1])
        elif run is not None:
            atomic_write_json(run.folder / CONFIG_FILE, run.config_document())

        # From here a signal only asks the run to stop: it ends after an iteration, with a checkpoint.
        with stop_requests() as stop:
            if run is not None:
                run.open_monitors(state[1].env_steps if state else 0)
            callbacks = {"on_progress": run.on_progress, "on_checkpoint": run.on_checkpoint} if run is not None else {}
            try:
                progress = fit(resume=state, should_stop=lambda: cluster.agreed_stop(stop), **callbacks)
            finally:
                if run is not None:
                    run.close_monitors()
        newest = str(run.run_folder.checkpoints()[-1]).encode() if run is not None else None
        checkpoint = Path(cluster.broadcast_bytes(newest).decode())  # process 0's, on every process
        if stop.requested:
            if run is not None:
                print(
                    f"{self.name}: stopped at {progress.env_steps} steps; checkpoint {checkpoint}\n"
                    f"resume with: {resume_command(RUN_OPTIONS, run.name)}",
                    flush=True,
                )
            raise stop.interrupted()
        if run is not None:
            failed = f"; {run.failed_episodes} episodes blew up" if run.failed_episodes else ""
            print(
                f"{self.name}: {progress.env_steps} steps in {run.wall_seconds:.1f} s "
                f"(compile {run.compile_seconds:.1f} s), mean return {run.last_return:.4g}{failed}; "
                f"checkpoint {checkpoint}"
            )
        return checkpoint

    @abstractmethod
    def saved_policy(self, settings: Any, checkpoint: Path, env: JaxEnv) -> SavedPolicy:
        """The deterministic policy a checkpoint of a run trained with `settings` (its config's) holds, for `env`: as
        rollouts take it, with its parameters and normaliser (a CorruptCheckpointError when they do not fit)."""

    @abstractmethod
    def exported_network(self, settings: Any) -> NetworkSettings:
        """The saved policy of a run trained with `settings` described as the MLP `joshua_ppo.export.mlp_policy`
        reads."""

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
        checkpoint, _, config = saved_training(run_dir, self.run_format, context.plugins.options())
        use_compile_cache()  # before anything compiles
        devices = len(jax.devices())
        env = environment(config, context, -(-episodes // devices) * devices)
        act, params, normalizer = self.saved_policy(context.settings(self.option, config), checkpoint, env)
        print(f"{self.name}: evaluating {checkpoint} ({checkpoint_step(checkpoint)} steps) over {episodes} episodes")
        rollout = make_rollout(env, act, env.task.episode_length, recorded=video_grid)
        episode = collect(rollout(params, normalizer, jax.random.PRNGKey(seed)), episodes)
        if video_path is not None:
            written = render_video(env.model, episode, video_path, fps=1.0 / env.task.dt)
            if written is not None:  # None: nothing can be drawn here, which render_video has said
                print(f"video: {written}", file=sys.stderr)
        return episode_results(episode)

    def export_policy(self, run_dir: Path, *, context: RunContext, trust_checkpoint: bool = False) -> ExportedPolicy:
        # msgpack runs no code: nothing to trust
        checkpoint, _, config = saved_training(run_dir, self.run_format, context.plugins.options())
        network = self.exported_network(context.settings(self.option, config))
        return ExportedPolicy(self.name, checkpoint, config, mlp_policy(checkpoint, network))


def _shared_resume(cluster: Cluster, resume: Resume | None) -> Resume | None:
    """Process 0's checkpoint to resume from and its payloads, on every process (None: a new run)."""
    checkpoint, payloads = resume or (None, {})
    shared = cluster.broadcast_bytes(str(checkpoint).encode() if checkpoint else None)
    if not shared:
        return None
    return Path(shared.decode()), {name: cluster.broadcast_bytes(payloads.get(name)) for name in RESUME_FILES}


class PpoTrainer(JaxTrainer):
    """PPO on the JAX environments of the configured backend; see the plugin README."""

    name = TRAINER_NAME
    run_format = RUN_FORMAT
    option = OPTION

    def train(self, config: TrainingConfig, context: RunContext) -> Path:
        settings: PpoSettings = context.settings(self.option, config)
        cache, cluster = self.prepare(config, settings.run)
        env = environment(config, context, training_envs=True)
        teacher = None
        if settings.teacher is not None:  # checked before anything is written
            teacher = load_teacher(settings.teacher, env, config.task, context, settings.network)
        # a bad batch layout is a config error before anything is written
        recompute = settings.returns.recompute_advantages
        check_settings(settings.rollout, settings.optimization, env.num_envs, env.mesh.size, whole_unrolls=recompute)
        rollout = settings.rollout
        check_one_iteration(settings.total_timesteps, env.num_envs, rollout.num_steps, rollout.unrolls_per_iteration)
        if teacher is not None and cluster.leader:
            print(f"ppo: imitating the teacher {teacher.description}")

        def fit(**loop: Any) -> Progress:
            groups = settings.groups
            return train_ppo(env, **groups, total_timesteps=settings.total_timesteps, seed=settings.seed,
                             checkpoint_interval=settings.checkpoint_interval, teacher=teacher, **loop)[1]  # fmt: skip

        return self.train_run(
            config,
            context,
            cluster,
            settings.run,
            lambda folder: PpoRun(config, settings, env, context, folder, cache),
            lambda checkpoint, payloads: load_state(checkpoint, env, settings, payloads),
            fit,
        )

    def saved_policy(self, settings: PpoSettings, checkpoint: Path, env: JaxEnv) -> SavedPolicy:
        params, normalizer = load_params(checkpoint, env, settings.network)
        return deterministic_policy(env, settings.network), params, normalizer

    def exported_network(self, settings: PpoSettings) -> NetworkSettings:
        return settings.network
