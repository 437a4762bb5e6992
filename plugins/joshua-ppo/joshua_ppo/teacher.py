"""A trained policy that the policy being trained imitates (`training.ppo.teacher`): loaded from its checkpoint and
applied inside the compiled iteration to the same minibatches as the PPO loss (`joshua_ppo.iteration`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp

from joshua_core.errors import ConfigError
from joshua_core.runs import METRICS_FILE, saved_training
from joshua_core.statistics import SUCCESS_METRIC
from joshua_core.tasks import METRIC_PREFIX
from joshua_ppo.checkpoints import RUN_FORMAT, load_params, read_json
from joshua_ppo.config_settings import PpoSettings
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
        mean, log_std, _ = self.net.apply({"params": self.params}, inputs)
        return jax.lax.stop_gradient((mean, jnp.broadcast_to(log_std, mean.shape)))


def load_teacher(settings: TeacherSettings, env: JaxEnv, task: str, options: Any, student: NetworkSettings) -> Teacher:
    """The teacher `settings` names, checked against the student: the same task (so the same flat observation and
    actions), a policy of the flat observation, actions squashed alike (the term compares the Gaussians before the
    squashing); `options`: the installed plugin options (`PluginHost.options()`), to read its config.json."""
    where = f"training.ppo.teacher.run {settings.run}"
    checkpoint, _, config = saved_training(Path(settings.run), RUN_FORMAT, options)
    if config.task != task:
        raise ConfigError(f"{where}: a policy of task '{config.task}', not '{task}'")
    network = PpoSettings.from_config(config).network
    if network.pixels is not None:
        raise ConfigError(f"{where}: a policy that sees camera images; the teacher must see the flat observation")
    if network.squash_actions != student.squash_actions:
        raise ConfigError(f"{where}: squash_actions {network.squash_actions}, the policy's {student.squash_actions}")
    params, normalizer = load_params(checkpoint, env, network)
    return Teacher(make_network(env, network), params, normalizer, network, settings.weight, _described(checkpoint))


def _described(checkpoint: Path) -> str:
    """The checkpoint with its training's last record: a teacher that had not learned the task yet teaches a
    policy that does not either (a pick-and-place teacher at a mean return of 955 left its pixel student at 0.09
    success), and the student's log is where that shows first."""
    record = (read_json(checkpoint / METRICS_FILE).get("history") or [{}])[-1]
    learned = [f"mean return {record['mean_return']:.4g}"] if record.get("mean_return") is not None else []
    success = record.get(METRIC_PREFIX + SUCCESS_METRIC)  # as the iteration logs the task's metrics
    if success is not None:
        learned.append(f"success {success:.3f}")
    last = f"; its last iteration: {', '.join(learned)}" if learned else ""
    return f"{checkpoint} ({record.get('step', 0):,} env steps{last})"
