"""One run of a JAX trainer being trained: its folder, history and monitors (progress bar, TensorBoard,
training-curve PNG, rollout MP4s, the live viewer, the web page), and the callbacks the training loop
(`joshua_ppo.train.run_iterations`) calls to report and checkpoint. What differs between the trainers (PPO, TD3,
SAC) is three things: their policy, what a checkpoint saves of their state, and their settings (`Run`'s abstract
methods; `PpoRun` here, `joshua_ppo.offpolicy_trainer.OffPolicyRun`). The checkpoint layout is in
`joshua_ppo.checkpoints`."""

from __future__ import annotations

import sys
import time
from abc import ABC, abstractmethod
from dataclasses import asdict
from importlib import metadata
from pathlib import Path
from typing import Any

import jax
import numpy as np

from joshua_core.atomic import atomic_write_json, json_safe
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.curves import write_training_curves
from joshua_core.options import message_to_dict
from joshua_core.progress import progress_bar
from joshua_core.run_context import RunContext
from joshua_core.runs import CONFIG_FILE, METRICS_FILE, RunFolder
from joshua_core.statistics import SUCCESS_METRIC
from joshua_core.tasks import METRIC_PREFIX
from joshua_jax import CompileCache, cache_reads
from joshua_ppo.checkpoints import RUN_FORMAT, checkpoint_payloads, read_metrics, write_checkpoint
from joshua_ppo.config_settings import PpoSettings
from joshua_ppo.envs import JaxEnv, environment
from joshua_ppo.iteration import FAILED
from joshua_ppo.policy import deterministic_policy, image_bytes_per_env
from joshua_ppo.rollout import Act, collect, make_rollout, render_video
from joshua_ppo.state import Progress
from joshua_ppo.train import IterationReport
from joshua_ppo.viewer import open_page, open_viewer
from joshua_render import LiveViewer, TrainingPage, render_optional

TRAINER_NAME = "ppo"
State = Any  # a trainer's training state: `params`, `normalizer`, `env_state` and `key` are all a run reads
# the task's success metric on the last step of the episodes that ended in the iteration, i.e. the success
# rate per iteration (tasks without one leave the panel out)
CURVE_SERIES = (
    "mean_return",
    METRIC_PREFIX + SUCCESS_METRIC,
    "mean_length",
    "policy_loss",
    "value_loss",
    "entropy",
    "steps_per_second",
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


class Run(ABC):
    """One run being trained: its folder, history and monitors; the callbacks the training loop calls. A trainer
    names itself (`trainer_name`, also the messages' prefix) and where its options live (`options_path`), and says
    what differs in the abstract methods; videos and the viewer follow its settings' `run` (RunSettings)."""

    trainer_name: str
    run_format: str
    options_path: str  # where the trainer's options live in a config, for messages (e.g. "training.ppo")

    def __init__(
        self,
        config: TrainingConfig,
        settings: Any,  # the trainer's settings dataclass: total_timesteps, seed and run besides its own
        env: JaxEnv,
        context: RunContext,
        run: RunFolder,
        cache: CompileCache,
    ) -> None:
        self.config = config
        self.cache = cache
        self._reads_before: tuple[int, int] | None = None  # cache reads when compiling began, until reported
        self.settings = settings
        self.env = env
        self.context = context
        self.run_folder = run
        self.name = run.name
        self.folder = run.path
        self.history: list[dict[str, float]] = []
        self.last_return = float("nan")
        self.failed_episodes = 0  # episodes whose simulation blew up, over the run (from the resumed run's on)
        self.compile_seconds = 0.0
        self.wall_seconds = 0.0
        self.bar: Any = None
        self.scalars: ScalarLog | None = None
        self.viewer: LiveViewer | None = None
        self.page: TrainingPage | None = None
        self._page_policy_step = 0  # the step the policy that made the next published poses was updated at
        self._rollout: tuple[JaxEnv, Any] | None = None

    @abstractmethod
    def policy(self, env: JaxEnv) -> Act:
        """The deterministic policy on `env`, as rollouts (videos) take it."""

    @abstractmethod
    def payloads(self, state: State, progress: Progress) -> dict[str, Any]:
        """Host copies of what a checkpoint saves of `state` (`joshua_ppo.checkpoints.write_payloads`)."""

    def settings_document(self) -> dict[str, Any]:
        """What config.json records of the settings beyond `asdict` of them."""
        return {}

    def config_document(self) -> dict[str, Any]:
        return {
            "trainer": self.trainer_name,
            "format": self.run_format,
            "run": self.name,
            "task": self.config.task,
            "model_path": str(self.config.model_path),
            "seed": self.settings.seed,
            "observation_size": self.env.observation_size,
            "action_size": self.env.action_size,
            **self.settings_document(),
            "devices": [str(device) for device in jax.devices()],
            "processes": jax.process_count(),
            "settings": asdict(self.settings),
            "training": message_to_dict(self.config),
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
            "failed_episodes": self.failed_episodes,
            "history": [record for record in self.history if record["step"] <= progress.env_steps],
        }

    def resumed_from(self, checkpoint: Path, progress: Progress) -> None:
        """Take on the history and last return of the checkpoint the run resumes from."""
        previous = read_metrics(checkpoint / METRICS_FILE)
        self.history = [record for record in previous.get("history", []) if record["step"] <= progress.env_steps]
        saved_return = previous.get("mean_return")  # null where it was not finite (json_safe)
        self.last_return = float("nan") if saved_return is None else float(saved_return)
        self.failed_episodes = sum(int(record.get(FAILED, 0)) for record in self.history)
        print(f"{self.trainer_name}: resuming {self.name} from {checkpoint.name} ({progress.env_steps} steps)")

    def open_monitors(self, start: int) -> None:
        """The progress bar (from `start` steps), TensorBoard log, live viewer and web page; the line saying training
        started."""
        title = f"JOSHUA {self.config.task}: {self.trainer_name}"
        self.page = open_page(self.config, self.env.model, self.env.num_envs, title)  # its URL line before the bar
        self._page_policy_step = start
        self.bar = progress_bar(
            self.settings.total_timesteps,
            description=f"{self.trainer_name} {self.config.task}",
            unit="steps",
            initial=start,
        )
        self.scalars = ScalarLog(self.folder / "tensorboard")
        self.viewer = open_viewer(self.settings.run, self.env.model, self.options_path)
        processes = jax.process_count()
        devices = ", ".join(str(device) for device in jax.devices())
        where = f"{len(jax.devices())} devices of {processes} processes" if processes > 1 else devices
        self._reads_before = cache_reads()
        self.bar.write(
            f"{self.trainer_name}: {self.env.num_envs} environments on {where}; compiling the training iteration "
            f"({self.cache.describe()})"
        )
        sys.stdout.flush()  # the line that says training started, for whoever waits on it

    def close_monitors(self) -> None:
        self.bar.close()
        if self.scalars is not None:
            self.scalars.close()
        if self.viewer is not None:
            self.viewer.close()
        if self.page is not None:
            self.page.close()

    # --- callbacks of the training loop ---

    def on_progress(self, report: IterationReport, state: State) -> None:
        metrics = report.metrics
        if metrics["episodes"] > 0:
            self.last_return = metrics["mean_return"]
        self.failed_episodes += int(metrics[FAILED])
        self.compile_seconds, self.wall_seconds = report.compile_seconds, report.wall_seconds
        if self._reads_before is not None:
            self.report_compiled(self._reads_before)
            self._reads_before = None
        record = {"step": report.env_steps, "steps_per_second": round(report.steps_per_second, 1)}
        record |= {name: value for name, value in metrics.items() if np.isfinite(value)}
        self.history.append(record)
        if self.scalars is not None:
            self.scalars.write(report.env_steps, {**metrics, "steps_per_second": report.steps_per_second})
        self.bar.set_description_str(
            f"{self.trainer_name} {self.config.task} return {self.last_return:.4g}", refresh=False
        )
        self.bar.update(report.env_steps - self.bar.n)
        interval = self.settings.run.video_interval
        if interval > 0 and report.iteration % interval == 0:
            self.record_video(state, report.env_steps)
        if self.viewer is not None:
            qpos = _first_local(state.env_state.data.qpos, self.viewer.envs)
            status = f"step {report.env_steps:,}  return {self.last_return:.4g}  {report.steps_per_second:,.0f} steps/s"
            if not self.viewer.show(qpos, status):
                self.viewer.close()
                self.viewer = None
        if self.page is not None:
            self.publish_to_page(self.page, report, state)

    def publish_to_page(self, page: TrainingPage, report: IterationReport, state: State) -> None:
        """The shown environments as this iteration's rollout left them (moved by the policy before its update) and
        the mean return of the episodes that ended in it; the page's own thread sends them, training never waits."""
        qpos = _first_local(state.env_state.data.qpos, page.envs)
        page.publish_poses(qpos, self._page_policy_step)
        self._page_policy_step = report.env_steps  # the policy just updated makes the next iteration's poses
        if report.metrics["episodes"] > 0:
            page.publish_return(report.env_steps, report.metrics["mean_return"], int(report.metrics[FAILED]))

    def report_compiled(self, reads_before: tuple[int, int]) -> None:
        """The line after the first iteration: how long compiling took and how much of it came from the cache."""
        hits, requests = (now - before for now, before in zip(cache_reads(), reads_before, strict=True))
        cached = f"{hits} of {requests} programs from the compilation cache" if self.cache.folder else "no cache"
        self.bar.write(f"{self.trainer_name}: compiled in {self.compile_seconds:.1f} s ({cached})")

    def on_checkpoint(self, state: State, progress: Progress, report: IterationReport | None) -> None:
        metrics = self.metrics_document(progress)
        documents = {CONFIG_FILE: self.config_document(), METRICS_FILE: metrics}
        write_checkpoint(self.run_folder, progress.env_steps, self.payloads(state, progress), documents)
        atomic_write_json(self.folder / METRICS_FILE, json_safe(metrics))
        write_training_curves(
            self.history,
            self.folder / "training_curves.png",
            title=f"{self.config.task}: {self.trainer_name}",
            series=CURVE_SERIES,
        )
        if report is not None and self.settings.run.video_interval == 0:
            self.record_video(state, progress.env_steps)

    def record_video(self, state: State, step: int) -> None:
        """Roll out the current deterministic policy for one episode and render it to videos/step_<N>.mp4; where
        nothing can be rendered, warn once and go on training (no rollouts for videos from then on)."""

        def film() -> Path | None:
            if self._rollout is None:  # on this process's devices: the others do not take part
                env = environment(self.config, self.context, jax.local_device_count(), jax.local_devices())
                steps = self.settings.run.video_steps or env.task.episode_length
                self._rollout = env, make_rollout(env, self.policy(env), steps)
            env, rollout = self._rollout
            params, normalizer = jax.device_get((state.params, state.normalizer))  # from every process's devices
            episode = collect(rollout(params, normalizer, jax.random.PRNGKey(step)))
            return render_video(env.model, episode, self.folder / "videos" / f"step_{step}.mp4", fps=1.0 / env.task.dt)

        path = render_optional("videos", film)
        if path is not None:
            self.bar.write(f"{self.trainer_name}: video {path}")


class PpoRun(Run):
    """A run of the `ppo` trainer."""

    trainer_name = TRAINER_NAME
    run_format = RUN_FORMAT
    options_path = "training.ppo"
    settings: PpoSettings

    def policy(self, env: JaxEnv) -> Act:
        return deterministic_policy(env, self.settings.network)

    def payloads(self, state: State, progress: Progress) -> dict[str, Any]:
        return checkpoint_payloads(state, progress)

    def settings_document(self) -> dict[str, Any]:
        # the camera images one iteration's rollout buffer holds (the epochs' shuffle copies it once more)
        rollout = self.settings.rollout
        per_env = image_bytes_per_env(self.env, self.settings.network)
        return {"rollout_image_bytes": per_env * self.env.num_envs * rollout.num_steps * rollout.unrolls_per_iteration}


def _first_local(array: jax.Array, count: int) -> np.ndarray:
    """The first `count` environments of `array` held by this process's devices (those of other
    processes cannot be read without them)."""
    shards = sorted(array.addressable_shards, key=lambda shard: shard.index[0].start or 0)
    return np.concatenate([np.asarray(shard.data) for shard in shards])[:count]


def _version(distribution: str) -> str:
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return "unknown"
