"""`joshua eval` for sb3: one episode per environment with the deterministic policy, the first few filmed live.

The first `grid` environments are rendered after every step into a `GridVideoWriter`, each tile labelled with
its return so far; a tile whose episode ended holds its last frame, labelled with its return and outcome.
"""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from numpy.typing import NDArray
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.vec_env import VecEnv

from joshua_core.interfaces import EpisodeResults
from joshua_core.statistics import SUCCESS_METRIC, SUCCESS_THRESHOLD
from joshua_render import GridVideoWriter, episode_label, render_optional
from joshua_sb3.vec_env import FAILED_KEY, METRICS_KEY


def roll_out(
    model: BaseAlgorithm,
    vec_env: VecEnv,
    environments: gymnasium.vector.VectorEnv,
    video_path: Path | None,
    grid: int = 1,
) -> EpisodeResults:
    """Run one episode in each environment of `vec_env` with the deterministic policy; film the first `grid`
    (where something can be rendered)."""
    episodes = vec_env.num_envs
    observations = vec_env.reset()
    finished: dict[int, dict[str, Any]] = {}
    running = np.zeros(episodes)
    fps = float(environments.metadata.get("render_fps", 30))
    # where nothing can be rendered, a warning says why and the episodes are rolled out without a video
    first = None if video_path is None else render_optional("video", lambda: _frames(environments, grid))
    with contextlib.ExitStack() as stack:  # the video is closed (finished) however the rollout ends
        writer = None if first is None else stack.enter_context(GridVideoWriter(video_path, fps, grid))
        if writer is not None:
            writer.write(first, [episode_label(i, 0.0) for i in range(grid)])
        while len(finished) < episodes:
            actions, _ = model.predict(observations, deterministic=True)  # type: ignore[arg-type]
            observations, rewards, dones, infos = vec_env.step(actions)
            ongoing = np.array([index not in finished for index in range(episodes)])
            running += np.where(ongoing, rewards, 0.0)
            for index in np.flatnonzero(dones):
                finished.setdefault(int(index), infos[index]["episode"])
            if writer is not None:
                # a finished environment already shows its next episode: its tile holds its last frame
                writer.write(
                    [None if i in finished else environments.render_frame(i) for i in range(grid)],
                    [_label(i, running, finished) for i in range(grid)],
                )
                if all(i in finished for i in range(grid)):
                    print(f"video: {writer.close()}")
                    writer = None
    ordered = [finished[index] for index in range(episodes)]
    return EpisodeResults(
        returns=[float(episode["r"]) for episode in ordered],
        lengths=[float(episode["l"]) for episode in ordered],
        metrics={name: [float(episode[METRICS_KEY][name]) for episode in ordered] for name in ordered[0][METRICS_KEY]},
        failed=[bool(episode.get(FAILED_KEY, False)) for episode in ordered],
    )


def _frames(environments: gymnasium.vector.VectorEnv, grid: int) -> list[NDArray[np.uint8]]:
    """The first `grid` environments' current frames."""
    return [environments.render_frame(i) for i in range(grid)]


def _label(index: int, running: NDArray[np.float64], finished: dict[int, dict[str, Any]]) -> str:
    """Tile `index`'s label: its return so far, or its episode's return and outcome once it ended."""
    if index not in finished:
        return episode_label(index, float(running[index]))
    metrics = finished[index][METRICS_KEY]
    outcome = bool(metrics[SUCCESS_METRIC] >= SUCCESS_THRESHOLD) if SUCCESS_METRIC in metrics else None
    return episode_label(index, float(finished[index]["r"]), outcome)
