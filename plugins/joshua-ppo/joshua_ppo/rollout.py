"""Rolling out a trained policy on MJX: evaluation results, and videos and viewer frames rendered by MuJoCo.

The rollout is one compiled `lax.scan` of the deterministic policy over whole episodes; what is
drawn afterwards (the first few environments' poses, commands and rewards) comes back to the host once,
and is rendered on the CPU with joshua-render's renderer (commands drawn as markers) into an MP4 of
labelled tiles by its `GridVideoWriter`.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import jax

from joshua_render import choose_headless_gl

choose_headless_gl()  # the trainers import mujoco here first: a MUJOCO_GL it cannot import with is disabled

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from joshua_core.interfaces import DEFAULT_RENDER_HEIGHT, DEFAULT_RENDER_WIDTH, EpisodeResults  # noqa: E402
from joshua_core.statistics import SUCCESS_METRIC, SUCCESS_THRESHOLD  # noqa: E402
from joshua_ppo.envs import JaxEnv  # noqa: E402
from joshua_ppo.normalizer import RunningStatistics  # noqa: E402
from joshua_render import camera_id, create_renderer, render_optional, render_with_commands  # noqa: E402


@dataclass
class Rollout:
    """One deterministic rollout: the recorded environments' frames, and the environments' first episodes."""

    # per recorded environment, from the reset state to its first episode's last step or the rollout's:
    qpos: list[np.ndarray]  # (frames, nq)
    commands: list[dict[str, np.ndarray]]  # (frames, k) per command
    running_returns: list[np.ndarray]  # (frames,) the return so far
    finished: np.ndarray  # (finished,) the indices of the environments that finished an episode
    returns: np.ndarray  # (finished,) their first episode's return
    lengths: np.ndarray  # (finished,)
    metrics: dict[str, np.ndarray]  # (finished,) each metric on the first episode's last step
    failed: np.ndarray  # (finished,) bool: the first episode's simulation blew up


Act = Callable[[Any, RunningStatistics, Any], jax.Array]  # (params, normaliser, environment state) -> actions


def make_rollout(env: JaxEnv, act: Act, steps: int, recorded: int = 1) -> Any:
    """A compiled function (params, normalizer, key) -> per-step arrays of a `steps`-long rollout of a trainer's
    deterministic policy `act` (e.g. `joshua_ppo.policy.deterministic_policy`); poses, commands and rewards of the
    first `recorded` environments are kept for videos."""

    def run(params: Any, stats: RunningStatistics, key: jax.Array) -> dict[str, Any]:
        state = env.reset(key)

        def step(state: Any, _: None) -> tuple[Any, dict[str, Any]]:
            action = act(params, stats, state)
            next_state = env.step(state, action)
            episode = next_state.episode
            record = {
                "qpos": next_state.data.qpos[:recorded],
                "commands": {name: value[:recorded] for name, value in next_state.commands.items()},
                "reward": next_state.reward[:recorded],
                "done": episode.done,
                "return": episode.return_,
                "length": episode.length,
                "metrics": episode.metrics,
                "failed": episode.failed,
            }
            return next_state, record

        _, records = jax.lax.scan(step, state, None, length=steps)
        first = {
            "qpos": state.data.qpos[:recorded],
            "commands": {name: value[:recorded] for name, value in state.commands.items()},
        }
        return {"first": first, "steps": records}

    return jax.jit(run)


def collect(raw: dict[str, Any], envs: int | None = None) -> Rollout:
    """Host-side summary of a rollout's arrays: each recorded environment's frames until its first episode
    ended (or the rollout did), and the first episode's results of each environment that finished one (of
    the first `envs`)."""
    raw = jax.device_get(raw)
    steps, first = raw["steps"], raw["first"]
    done = np.asarray(steps["done"])[:, :envs]  # (T, N)
    finished = np.flatnonzero(done.any(axis=0))
    first_end = done[:, finished].argmax(axis=0)  # step index of each finished environment's first episode end
    rollout = Rollout([], [], [], finished, *_first_episodes(steps, first_end, finished))
    for index in range(np.asarray(first["qpos"]).shape[0]):
        # The state after the last step of an episode is already the next episode's reset: leave it out.
        end = int(done[:, index].argmax()) if done[:, index].any() else done.shape[0]
        rollout.qpos.append(_frames(first["qpos"], steps["qpos"], index, end))
        commands = first["commands"].items()
        rollout.commands.append({name: _frames(value, steps["commands"][name], index, end) for name, value in commands})
        rollout.running_returns.append(np.concatenate([[0.0], np.cumsum(np.asarray(steps["reward"])[:end, index])]))
    return rollout


def _frames(start: Any, recorded: Any, index: int, end: int) -> np.ndarray:
    """Environment `index`'s value in the reset state followed by its values after the first `end` steps."""
    return np.concatenate([np.asarray(start)[index][None], np.asarray(recorded)[:end, index]])


def _first_episodes(
    steps: dict[str, Any], first_end: np.ndarray, finished: np.ndarray
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], np.ndarray]:
    """(returns, lengths, metrics, failed) of the finished environments' first episodes."""
    return (
        np.asarray(steps["return"])[first_end, finished],
        np.asarray(steps["length"])[first_end, finished],
        {name: np.asarray(value)[first_end, finished] for name, value in steps["metrics"].items()},
        np.asarray(steps["failed"])[first_end, finished],
    )


def tile_label(rollout: Rollout, index: int, frame: int) -> str:
    """The label of recorded environment `index` on video frame `frame`: its return so far, and on its
    episode's last frame and after, the episode's return and (for tasks with a success metric) its outcome."""
    from joshua_render import episode_label  # with the video writer, which needs PyAV

    last = len(rollout.qpos[index]) - 1
    position = np.flatnonzero(rollout.finished == index)
    if frame < last or not position.size:
        return episode_label(index, float(rollout.running_returns[index][min(frame, last)]))
    success = rollout.metrics.get(SUCCESS_METRIC)
    outcome = None if success is None else bool(success[position[0]] >= SUCCESS_THRESHOLD)
    return episode_label(index, float(rollout.returns[position[0]]), outcome)


def render_video(
    model: mujoco.MjModel, rollout: Rollout, path: Path, fps: float, camera: str | None = None
) -> Path | None:
    """Render the recorded environments' episodes, tiled and labelled, to an MP4 at `path` (returned), with
    their commands drawn as markers; a tile whose episode ended holds its last frame. Where nothing can be
    rendered, None, after a warning: a video never ends a training or an evaluation."""
    return render_optional("videos", lambda: _render_video(model, rollout, path, fps, camera))


def _render_video(model: mujoco.MjModel, rollout: Rollout, path: Path, fps: float, camera: str | None) -> Path:
    tiles = len(rollout.qpos)
    from joshua_render import GridVideoWriter  # PyAV: only where a video is written

    writer = GridVideoWriter(path, fps, tiles)
    model = copy.deepcopy(model)  # drawing commands moves marker sites of the model it draws
    data = mujoco.MjData(model)
    renderer = create_renderer(model, DEFAULT_RENDER_WIDTH, DEFAULT_RENDER_HEIGHT)
    camera_index = camera_id(model, camera)

    def draw(index: int, frame: int) -> np.ndarray | None:
        if frame >= len(rollout.qpos[index]):
            return None
        data.qpos[:] = rollout.qpos[index][frame]
        mujoco.mj_forward(model, data)
        commands = {name: value[frame] for name, value in rollout.commands[index].items()}
        return render_with_commands(renderer, model, data, camera_index, commands)

    try:
        with writer:
            for frame in range(max(len(qpos) for qpos in rollout.qpos)):
                labels = [tile_label(rollout, index, frame) for index in range(tiles)]
                writer.write([draw(index, frame) for index in range(tiles)], labels)
            return writer.close()
    finally:
        renderer.close()


def episode_results(rollout: Rollout) -> EpisodeResults:
    """The finished environments' first episodes, for `joshua_core.statistics.summarize`."""
    return EpisodeResults(
        returns=rollout.returns.tolist(),
        lengths=rollout.lengths.tolist(),
        metrics={name: values.tolist() for name, values in rollout.metrics.items()},
        failed=rollout.failed.tolist(),
    )
