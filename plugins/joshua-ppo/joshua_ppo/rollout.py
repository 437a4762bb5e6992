"""Rolling out a trained policy on MJX: evaluation statistics, and videos and viewer frames rendered by MuJoCo.

The rollout is one compiled `lax.scan` of the deterministic policy over whole episodes; what is
drawn afterwards (env 0's poses, its commands) comes back to the host once, and is rendered on the
CPU with joshua-render's renderer (commands drawn as markers) into an MP4 by its `VideoWriter`.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import jax
import mujoco
import numpy as np

from joshua_core.interfaces import DEFAULT_RENDER_HEIGHT, DEFAULT_RENDER_WIDTH
from joshua_ppo.envs import JaxEnv
from joshua_ppo.normalizer import RunningStatistics
from joshua_ppo.policy import make_network, policy_actions
from joshua_ppo.settings import NetworkSettings
from joshua_render import VideoWriter, camera_id, create_renderer, render_with_commands


@dataclass
class Rollout:
    """One deterministic rollout: env 0's poses and commands, and the environments' first episodes."""

    qpos: np.ndarray  # (frames, nq) env 0, from the reset state to its first episode's last step or the rollout's
    commands: dict[str, np.ndarray]  # (frames, k) env 0's commands, per frame
    returns: np.ndarray  # (finished,) the first episode's return of each environment that finished one
    lengths: np.ndarray  # (finished,)
    metrics: dict[str, np.ndarray]  # (finished,) each metric on the first episode's last step


def make_rollout(env: JaxEnv, network: NetworkSettings, steps: int) -> Any:
    """A compiled function (params, normalizer, key) -> per-step arrays of a `steps`-long rollout of the
    deterministic policy of the network `network` describes."""
    net = make_network(env, network)

    def run(params: Any, stats: RunningStatistics, key: jax.Array) -> dict[str, Any]:
        state = env.reset(key)

        def step(state: Any, _: None) -> tuple[Any, dict[str, Any]]:
            action = policy_actions(net, params, stats, state.observation, network)
            next_state = env.step(state, action)
            episode = next_state.episode
            record = {
                "qpos": next_state.data.qpos[0],
                "commands": {name: value[0] for name, value in next_state.commands.items()},
                "done": episode.done,
                "return": episode.return_,
                "length": episode.length,
                "metrics": episode.metrics,
            }
            return next_state, record

        _, records = jax.lax.scan(step, state, None, length=steps)
        first = {"qpos": state.data.qpos[0], "commands": {name: value[0] for name, value in state.commands.items()}}
        return {"first": first, "steps": records}

    return jax.jit(run)


def collect(raw: dict[str, Any], envs: int | None = None) -> Rollout:
    """Host-side summary of a rollout's arrays: env 0's frames until its first episode ended (or the rollout
    did), and the first episode's statistics of each environment that finished one (of the first `envs`)."""
    raw = jax.device_get(raw)
    steps = raw["steps"]
    done = np.asarray(steps["done"])[:, :envs]  # (T, N)
    finished = np.flatnonzero(done.any(axis=0))
    first_end = done[:, finished].argmax(axis=0)  # step index of each finished environment's first episode end
    # The state after the last step of env 0's episode is already the next episode's reset: leave it out.
    end0 = int(done[:, 0].argmax()) if done[:, 0].any() else done.shape[0]
    qpos = np.concatenate([np.asarray(raw["first"]["qpos"])[None], np.asarray(steps["qpos"])[:end0]])
    commands = {
        name: np.concatenate([np.asarray(value)[None], np.asarray(steps["commands"][name])[:end0]])
        for name, value in raw["first"]["commands"].items()
    }
    return Rollout(
        qpos=qpos,
        commands=commands,
        returns=np.asarray(steps["return"])[first_end, finished],
        lengths=np.asarray(steps["length"])[first_end, finished],
        metrics={name: np.asarray(value)[first_end, finished] for name, value in steps["metrics"].items()},
    )


def render_video(
    model: mujoco.MjModel, rollout: Rollout, path: Path, fps: float, camera: str | None = None
) -> Path:
    """Render env 0's episode to an MP4 at `path` (returned), with its commands drawn as markers."""
    writer = VideoWriter(path, fps)
    model = copy.deepcopy(model)  # drawing commands moves marker sites of the model it draws
    data = mujoco.MjData(model)
    renderer = create_renderer(model, DEFAULT_RENDER_WIDTH, DEFAULT_RENDER_HEIGHT)
    camera_index = camera_id(model, camera)
    try:
        with writer:
            for index, qpos in enumerate(rollout.qpos):
                data.qpos[:] = qpos
                mujoco.mj_forward(model, data)
                commands = {name: value[index] for name, value in rollout.commands.items()}
                writer.write(render_with_commands(renderer, model, data, camera_index, commands))
            return writer.close()
    finally:
        renderer.close()


def mean_results(rollout: Rollout) -> dict[str, float]:
    """`mean_return`, `mean_length` and `final_<metric>` averaged over the environments' first episodes."""
    results = {"mean_return": float(np.mean(rollout.returns)), "mean_length": float(np.mean(rollout.lengths))}
    results |= {f"final_{name}": float(np.mean(values)) for name, values in rollout.metrics.items()}
    return results
