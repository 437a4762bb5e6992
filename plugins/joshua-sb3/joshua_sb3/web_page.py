"""The web page of an SB3 training (`training.web`, `--web`): a few training environments moved by the policy being
trained, the mean episode return of each rollout and the episodes that blew up, published to joshua_render's
TrainingPage."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from joshua_core.config_pb2 import TrainingConfig
from joshua_render import TrainingPage, open_training_page
from joshua_sb3.vec_env import blown_up, ended_episodes

PAGE_ENVS = 4  # environments shown side by side (fewer when the run has fewer)


def open_page(config: TrainingConfig, environments: Any, title: str) -> TrainingPage | None:
    """The page at `config.web` (None when unset, or when it cannot listen there: training goes on, and says so)."""
    if not config.web:
        return None
    return open_training_page(environments.model, min(PAGE_ENVS, environments.num_envs), config.web, title=title)


class PagePublisher(BaseCallback):
    """Publishes the shown environments' poses at most TrainingPage.PUSH_HZ times a second (a clock read per step
    otherwise), each rollout's mean return and its blown-up episodes; the page's own thread does the rest, so
    training never waits."""

    def __init__(self, page: TrainingPage, environments: Any) -> None:
        super().__init__()
        self.page = page
        self.environments = environments
        self.next_push = 0.0
        self.policy_step = 0  # the step at which the policy last changed: the end of the last rollout
        self.failed = 0  # episodes of this rollout whose simulation blew up

    def _on_step(self) -> bool:
        now = time.perf_counter()
        if now >= self.next_push:
            self.next_push = now + 1.0 / TrainingPage.PUSH_HZ
            self.page.publish_poses(self.environments.qpos, self.policy_step)
        self.failed += blown_up(ended_episodes(self.locals["infos"], self.locals["dones"]))
        return True

    def _on_rollout_start(self) -> None:
        self.policy_step = int(self.model.num_timesteps)  # the policy was just updated from the last rollout

    def _on_rollout_end(self) -> None:
        episodes = list(self.model.ep_info_buffer or [])
        if episodes:
            mean_return = float(np.mean([episode["r"] for episode in episodes]))
            self.page.publish_return(self.model.num_timesteps, mean_return, self.failed)
            self.failed = 0
