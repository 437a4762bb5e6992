"""Trainers `td3` and `sac`: off-policy learning on JAX environments (`joshua_ppo.offpolicy_train`) with what a
PPO run has: run folders, atomic checkpoints and resume, monitors, `joshua eval` and export, all shared with the
`ppo` trainer (`joshua_ppo.trainer.JaxTrainer`, `joshua_ppo.run.Run`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.limits import check_one_iteration
from joshua_core.run_context import RunContext
from joshua_core.runs import RunFolder
from joshua_ppo.envs import JaxEnv, environment
from joshua_ppo.offpolicy_iteration import make_actor
from joshua_ppo.offpolicy_settings import OPTIONS, OffPolicySettings, check_batch
from joshua_ppo.offpolicy_train import (
    RUN_FORMAT,
    checkpoint_payloads,
    exported_network,
    load_actor,
    load_state,
    offpolicy_policy,
    train_offpolicy,
)
from joshua_ppo.rollout import Act
from joshua_ppo.run import Run, State
from joshua_ppo.settings import NetworkSettings
from joshua_ppo.state import Progress
from joshua_ppo.trainer import JaxTrainer, SavedPolicy


class OffPolicyRun(Run):
    """A run of the `td3` or `sac` trainer."""

    run_format = RUN_FORMAT
    options_path = OPTIONS
    settings: OffPolicySettings

    def __init__(
        self,
        config: TrainingConfig,
        settings: OffPolicySettings,
        env: JaxEnv,
        context: RunContext,
        run: RunFolder,
        cache: Any,
    ) -> None:
        self.trainer_name = settings.algorithm
        super().__init__(config, settings, env, context, run, cache)

    def policy(self, env: JaxEnv) -> Act:
        return offpolicy_policy(env, self.settings)

    def payloads(self, state: State, progress: Progress) -> dict[str, Any]:
        return checkpoint_payloads(state, progress)


class OffPolicyTrainer(JaxTrainer):
    """TD3 or SAC (`name`) on the JAX environments of the configured backend; docs/training-offpolicy.md."""

    run_format = RUN_FORMAT
    option = OPTIONS.rpartition(".")[2]

    def train(self, config: TrainingConfig, context: RunContext) -> Path:
        settings: OffPolicySettings = context.settings(self.option, config)
        cache, cluster = self.prepare(config, settings.run)
        env = environment(config, context, training_envs=True)
        make_actor(env, settings)  # a pixel actor's cameras and terms are checked before anything is written
        check_batch(settings, env.num_envs, env.mesh.size)
        check_one_iteration(settings.total_timesteps, env.num_envs, settings.steps_per_iteration, 1)

        def fit(**loop: Any) -> Progress:
            return train_offpolicy(env, settings, **loop)[1]

        return self.train_run(
            config,
            context,
            cluster,
            settings.run,
            lambda folder: OffPolicyRun(config, settings, env, context, folder, cache),
            lambda checkpoint, payloads: load_state(checkpoint, env, settings, payloads),
            fit,
        )

    def saved_policy(self, settings: OffPolicySettings, checkpoint: Path, env: JaxEnv) -> SavedPolicy:
        params, normalizer = load_actor(checkpoint, env, settings)
        return offpolicy_policy(env, settings), params, normalizer

    def exported_network(self, settings: OffPolicySettings) -> NetworkSettings:
        return exported_network(settings)


class Td3Trainer(OffPolicyTrainer):
    """TD3 as FastTD3 runs it, on thousands of JAX environments."""

    name = "td3"


class SacTrainer(OffPolicyTrainer):
    """SAC with a learned temperature, on thousands of JAX environments."""

    name = "sac"
