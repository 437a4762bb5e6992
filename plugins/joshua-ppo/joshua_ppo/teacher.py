"""A trained policy that the policy being trained imitates (`training.ppo.teacher`): loaded from its checkpoint and
applied inside the compiled iteration to the same minibatches as the PPO loss (`joshua_ppo.iteration`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp

from joshua_core.errors import ConfigError, CorruptCheckpointError
from joshua_core.run_context import RunContext
from joshua_core.runs import METRICS_FILE, saved_training
from joshua_core.statistics import SUCCESS_METRIC
from joshua_core.tasks import METRIC_PREFIX
from joshua_ppo.checkpoints import RUN_FORMAT, load_params, read_metrics
from joshua_ppo.config_settings import OPTION
from joshua_ppo.envs import JaxEnv
from joshua_ppo.normalizer import RunningStatistics, normalize
from joshua_ppo.policy import Network, make_network
from joshua_ppo.settings import NetworkSettings, TeacherSettings


class Teacher(NamedTuple):
    """A loaded teacher: its network, parameters and observation normaliser, and the imitation term's weight."""

    net: Network
    params: Any
    normalizer: RunningStatistics
    network: NetworkSettings
    weight: float
    description: str  # its checkpoint and how far it had learned, for the run's log

    def distribution(self, observation: jax.Array) -> tuple[jax.Array, jax.Array]:
        """The teacher's Gaussian (mean, log_std, before any squashing) for raw flat observations; constants to the
        gradient."""
        inputs = normalize(self.normalizer, observation, self.network.normalize_observations)
        mean, log_std, _ = self.net.apply({"params": self.params}, inputs)  # type: ignore[misc]  # without mutable, apply gives the output alone
        return jax.lax.stop_gradient((mean, jnp.broadcast_to(log_std, mean.shape)))


def load_teacher(
    settings: TeacherSettings, env: JaxEnv, task: str, context: RunContext, student: NetworkSettings
) -> Teacher:
    """The teacher `settings` names, checked against the student: the same task (so the same flat observation and
    actions), a policy of the flat observation, actions squashed alike (the term compares the Gaussians before the
    squashing); `context`: the run's, whose plugins read its config.json and resolve its settings."""
    where = f"training.ppo.teacher.run {settings.run}"
    checkpoint, _, config = saved_training(Path(settings.run), RUN_FORMAT, context.plugins.options())
    if config.task != task:
        raise ConfigError(f"{where}: a policy of task '{config.task}', not '{task}'")
    network = context.settings(OPTION, config).network
    if network.pixels is not None:
        raise ConfigError(f"{where}: a policy that sees camera images; the teacher must see the flat observation")
    if network.squash_actions != student.squash_actions:
        raise ConfigError(f"{where}: squash_actions {network.squash_actions}, the policy's {student.squash_actions}")
    params, normalizer = load_params(checkpoint, env, network)
    return Teacher(make_network(env, network), params, normalizer, network, settings.weight, _described(checkpoint))


def _described(checkpoint: Path) -> str:
    """The checkpoint with its training's last record: a teacher that had not learned the task yet teaches a
    policy that does not either (a pick-and-place teacher at a mean return of 955 left its pixel student at 0.09
    success), and the student's log is where that shows first. A metrics.json of other types is a
    CorruptCheckpointError naming the file (exit 2)."""
    path = checkpoint / METRICS_FILE
    history = read_metrics(path).get("history") or [{}]
    record = history[-1] if isinstance(history, list) else None
    if not isinstance(record, dict):
        raise CorruptCheckpointError(f"{path}: 'history' is not a list of records (objects)")
    step, mean_return, success = (
        _number(path, record, key) for key in ("step", "mean_return", METRIC_PREFIX + SUCCESS_METRIC)
    )
    learned = [f"mean return {mean_return:.4g}"] if mean_return is not None else []
    if success is not None:  # as the iteration logs the task's metrics
        learned.append(f"success {success:.3f}")
    last = f"; its last iteration: {', '.join(learned)}" if learned else ""
    return f"{checkpoint} ({step or 0:,} env steps{last})"


def _number(path: Path, record: dict[str, Any], key: str) -> float | None:
    """The number `record` holds under `key`, or None when it holds none; any other value is a
    CorruptCheckpointError naming `path`, the file the record is from."""
    value = record.get(key)
    if value is None or (isinstance(value, int | float) and not isinstance(value, bool)):
        return value
    raise CorruptCheckpointError(f"{path}: the last record's '{key}' is a {type(value).__name__}, not a number")
