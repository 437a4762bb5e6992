"""A third-party trainer in one file: random actions on any backend's NUMPY environments (docs/writing-plugins.md,
"Adding a backend or trainer"). Everything but the policy comes from the core and the backend."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.interfaces import EnvKind, Trainer
from joshua_core.run_context import RunContext
from joshua_core.runs import CONFIG_FILE, create_run


class RandomTrainer(Trainer):
    """Steps uniformly random actions for `total_timesteps` and keeps the finished episodes' returns."""

    def train(self, config: TrainingConfig, context: RunContext) -> Path:
        # the backend the config names, num_envs, seed, task overrides, desynchronised episodes: the core's
        envs = context.create_envs(config, EnvKind.NUMPY, training_envs=True)
        envs.reset(seed=config.seed)
        returns: list[float] = []
        for _ in range(max(1, config.total_timesteps // envs.num_envs)):
            # the backend's step order, autoreset and episode bookkeeping (joshua_core.tasks.account_step)
            *_, info = envs.step(envs.action_space.sample())
            if "episode" in info:
                returns += info["episode"]["r"][info["_episode"]].tolist()
        envs.close()
        # a unique, locked run folder and an atomic checkpoint: joshua_core.runs
        with create_run(context.output_dir, None, stem=config.task, options="training") as run:
            (run.path / CONFIG_FILE).write_text(json.dumps({"trainer": "random", "task": config.task}))
            with run.publish(config.total_timesteps) as folder:
                summary = {"episodes": len(returns), "mean_return": float(np.mean(returns)) if returns else None}
                (folder / "returns.json").write_text(json.dumps(summary))
        return run.checkpoint_path(config.total_timesteps)
