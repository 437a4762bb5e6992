"""Trainer `ppo`: a TrainingConfig turned into `train_ppo` on JAX environments (EnvKind.JAX, from the backend
the config names: `mjx`, or another that provides them), with run folders,
checkpoints, resume and monitoring (`joshua_ppo.run`), and the evaluation of a saved run."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

import jax
from google.protobuf import json_format

from joshua_core.atomic import atomic_write_json
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError, UsageError
from joshua_core.interfaces import RunContext, Trainer
from joshua_core.interrupts import resume_command, stop_requests
from joshua_core.options import options_of, parse_dict
from joshua_core.progress import progress_bar
from joshua_core.runs import (
    CONFIG_FILE,
    METRICS_FILE,
    RunFolder,
    checkpoint_step,
    create_run,
    read_run_config,
    resolve_checkpoint,
    resume_run,
)
from joshua_ppo import options_pb2
from joshua_ppo.checkpoints import load_params, load_state, read_json
from joshua_ppo.config_settings import PpoSettings
from joshua_ppo.envs import JaxEnv, environment
from joshua_ppo.rollout import collect, make_rollout, mean_results, render_video
from joshua_ppo.run import RUN_FORMAT, TRAINER_NAME, Run, ScalarLog
from joshua_ppo.settings import check_settings
from joshua_ppo.state import Progress, TrainingState
from joshua_ppo.train import train_ppo
from joshua_ppo.viewer import open_viewer

OPTIONS = "training.ppo"  # where the run options live, for hints


def _open_run(config: TrainingConfig, root: Path) -> tuple[RunFolder, Path | None]:
    """The run folder, locked, and the checkpoint to resume from (None for a new run)."""
    options = options_of(config, options_pb2.ppo)
    if not options.resume:
        return create_run(root, options.run_name or None, stem=config.task, options=OPTIONS), None
    run, saved = resume_run(root, options.run_name or None, trainer=TRAINER_NAME, options=OPTIONS)
    if saved.get("task") != config.task:
        run.close()
        raise ConfigError(
            f"{OPTIONS}.resume: run '{run.name}' trained task '{saved.get('task')}', "
            f"this config asks for '{config.task}'"
        )
    checkpoints = run.checkpoints()
    if not checkpoints:
        run.close()
        raise ConfigError(f"{OPTIONS}.resume: run '{run.name}' in {root} has no checkpoint to resume from")
    return run, checkpoints[-1]


class PpoTrainer(Trainer):
    """PPO on the JAX environments of the configured backend; see the plugin README."""

    def train(self, config: TrainingConfig, context: RunContext) -> Path:
        settings = PpoSettings.from_config(config)
        env = environment(config, context)
        # a bad batch layout is a config error before anything is written
        recompute = settings.returns.recompute_advantages
        check_settings(settings.rollout, settings.optimization, env.num_envs, env.mesh.size, whole_unrolls=recompute)
        folder, resume_from = _open_run(config, context.output_dir)
        with folder:  # locked while training
            return self._train(config, settings, env, Run(config, settings, env, context, folder), resume_from)

    def _train(
        self, config: TrainingConfig, settings: PpoSettings, env: JaxEnv, run: Run, resume_from: Path | None
    ) -> Path:
        resume = None
        if resume_from is not None:
            resume = load_state(resume_from, env, settings)
            previous = read_json(resume_from / METRICS_FILE)
            run.history = [record for record in previous.get("history", []) if record["step"] <= resume[1].env_steps]
            saved_return = previous.get("mean_return")  # null where it was not finite (json_safe)
            run.last_return = float("nan") if saved_return is None else float(saved_return)
            print(f"ppo: resuming {run.name} from {resume_from.name} ({resume[1].env_steps} steps)")
        else:
            atomic_write_json(run.folder / CONFIG_FILE, run.config_document())
        start = resume[1].env_steps if resume else 0
        # From here a signal only asks the run to stop: it ends after an iteration, with a checkpoint.
        with stop_requests() as stop:
            run.bar = progress_bar(settings.total_timesteps, description=f"ppo {config.task}", unit="steps", initial=start)
            run.scalars = ScalarLog(run.folder / "tensorboard")
            run.viewer = open_viewer(options_of(config, options_pb2.ppo), env.model)
            devices = ", ".join(str(device) for device in jax.devices())
            run.bar.write(f"ppo: {env.num_envs} environments on {devices}; compiling the training iteration")
            sys.stdout.flush()  # the line that says training started, for whoever waits on it
            progress = self._run(settings, env, run, resume, should_stop=lambda: stop.requested)
        checkpoint = run.run_folder.checkpoints()[-1]
        if stop.requested:
            print(
                f"ppo: stopped at {progress.env_steps} steps; checkpoint {checkpoint}\n"
                f"resume with: {resume_command(OPTIONS, run.name)}",
                flush=True,
            )
            raise stop.interrupted()
        print(
            f"ppo: {progress.env_steps} steps in {run.wall_seconds:.1f} s (compile {run.compile_seconds:.1f} s), "
            f"mean return {run.last_return:.4g}; checkpoint {checkpoint}"
        )
        return checkpoint

    @staticmethod
    def _run(
        settings: PpoSettings,
        env: JaxEnv,
        run: Run,
        resume: tuple[TrainingState, Progress] | None,
        should_stop: Callable[[], bool],
    ) -> Progress:
        """`train_ppo` with the run's callbacks; the progress bar, logs and viewer are closed however it ends."""
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
                should_stop=should_stop,
            )
        finally:
            run.bar.close()
            run.scalars.close()
            if run.viewer is not None:
                run.viewer.close()
        return progress

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
        saved = read_run_config(checkpoint)  # unreadable: a one-line error, exit 2 (as for sb3)
        if saved.get("format") != RUN_FORMAT:
            raise UsageError(f"{checkpoint / CONFIG_FILE} is not a {RUN_FORMAT} run config")
        config = TrainingConfig()
        try:
            parse_dict(saved["training"], config, context.plugins.options())
        except (KeyError, json_format.ParseError) as error:
            raise UsageError(f"{checkpoint / CONFIG_FILE}: unreadable training config: {error}") from None
        settings = PpoSettings.from_config(config)
        devices = len(jax.devices())
        env = environment(config, context, -(-episodes // devices) * devices)
        params, normalizer = load_params(checkpoint, env, settings.network)
        print(f"ppo: evaluating {checkpoint} ({checkpoint_step(checkpoint)} steps) over {episodes} episodes")
        rollout = make_rollout(env, settings.network, env.task.episode_length)
        episode = collect(rollout(params, normalizer, jax.random.PRNGKey(seed)), episodes)
        if video_path is not None:
            written = render_video(env.model, episode, video_path, fps=1.0 / env.task.dt)
            print(f"video: {written}", file=sys.stderr)
        return mean_results(episode)
