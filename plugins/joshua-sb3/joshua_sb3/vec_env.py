"""An SB3 `VecEnv` over a Gymnasium `VectorEnv` that resets finished environments in the same step.

Gymnasium's SAME_STEP autoreset and SB3's VecEnv agree on the essentials: the step that ends an
episode returns the first observation of the next one. They differ in where the last observation
goes (Gymnasium: `infos["final_obs"]`, one batched dict; SB3: `infos[i]["terminal_observation"]`,
a list of per-environment dicts) and in how truncation is reported. This adapter translates the
batch with array operations; only environments whose episode ended get per-environment work.

It also keeps the episode statistics SB3's `Monitor` would (`info["episode"]` with return `r`,
length `l` and time `t`), plus each reward term's episode sum, the task's metrics at the end of
the episode and whether its simulation blew up (`failed`), so callbacks can log them from
`model.ep_info_buffer`.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode
from numpy.typing import NDArray
from stable_baselines3.common.vec_env import VecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs, VecEnvStepReturn

REWARD_TERMS_KEY = "reward_terms"  # infos[key][name]: per-environment weighted reward of one term this step
METRICS_KEY = "metrics"  # infos[key][name]: per-environment task metric (e.g. "distance") after this step
FAILED_KEY = "failed"  # info["episode"][key]: the episode ended because its simulation blew up


class BatchVecEnv(VecEnv):
    """What an SB3 VecEnv over one batched environment object (`self.env`) shares with every other: actions
    are taken in `step_async`, and attributes and methods are the batch's, shared by every index."""

    env: Any
    _actions: NDArray[Any] | None

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        # VecEnv.__init__ asks for render_mode, which a batch need not have
        value = getattr(self.env, attr_name, None) if attr_name == "render_mode" else getattr(self.env, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        setattr(self.env, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any
    ) -> list[Any]:
        result = getattr(self.env, method_name)(*method_args, **method_kwargs)
        return [result for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type[gymnasium.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]


def ended_episodes(infos: Sequence[dict[str, Any]], dones: NDArray[Any]) -> list[dict[str, Any]]:
    """The `episode` records SB3's step infos hold for the environments whose episode ended at this step."""
    return [infos[int(index)].get("episode", {}) for index in np.flatnonzero(dones)]


def blown_up(episodes: Sequence[dict[str, Any]]) -> int:
    """How many of `episodes` (their `episode` records) ended because their simulation blew up."""
    return sum(bool(episode.get(FAILED_KEY, False)) for episode in episodes)


def episode_info(
    final_observation: NDArray[Any],
    terminated: bool,
    truncated: bool,
    episode: dict[str, Any],
) -> dict[str, Any]:
    """SB3's info of an environment whose episode just ended: its last observation, whether the time limit ended
    it, and `episode` (r, l, t, reward_terms, metrics, failed), which Monitor-style loggers and the trainer read."""
    return {
        "terminal_observation": np.asarray(final_observation),
        "TimeLimit.truncated": bool(truncated and not terminated),
        "episode": episode,
    }


class SameStepVecEnv(BatchVecEnv):
    """SB3 view of a batched Gymnasium vector environment with `AutoresetMode.SAME_STEP`."""

    def __init__(self, env: gymnasium.vector.VectorEnv) -> None:
        mode = env.metadata.get("autoreset_mode")
        if mode != AutoresetMode.SAME_STEP:
            raise ValueError(f"SameStepVecEnv needs a vector env with autoreset_mode SAME_STEP, got {mode!r}")
        self.env = env  # before VecEnv.__init__, which reads render_mode through get_attr
        super().__init__(env.num_envs, env.single_observation_space, env.single_action_space)
        self.metadata = env.metadata
        self._actions: NDArray[Any] | None = None
        self._started = time.perf_counter()
        self._returns = np.zeros(self.num_envs, dtype=np.float64)
        self._lengths = np.zeros(self.num_envs, dtype=np.int64)
        self._term_sums: dict[str, NDArray[np.float64]] = {}

    def reset(self) -> VecEnvObs:
        # SB3 seeds environment i with seed + i; Gymnasium's vector reset does the same from one int.
        seed = self._seeds[0]
        options = self._options[0] or None
        observations, infos = self.env.reset(seed=seed, options=options)
        self._reset_seeds()
        self._reset_options()
        self._returns[:] = 0.0
        self._lengths[:] = 0
        self._term_sums.clear()
        return observations

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_wait() called without step_async()")
        observations, rewards, terminated, truncated, infos = self.env.step(self._actions)
        self._actions = None
        dones = np.logical_or(terminated, truncated)
        self._returns += rewards
        self._lengths += 1
        for name, values in infos.get(REWARD_TERMS_KEY, {}).items():
            self._term_sums.setdefault(name, np.zeros(self.num_envs))[:] += values
        env_infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        finished = np.flatnonzero(dones)
        if finished.size:
            self._finish_episodes(finished, env_infos, terminated, truncated, infos)
        return observations, np.asarray(rewards, dtype=np.float32), dones, env_infos

    def _finish_episodes(
        self,
        finished: NDArray[np.intp],
        env_infos: list[dict[str, Any]],
        terminated: NDArray[np.bool_],
        truncated: NDArray[np.bool_],
        infos: dict[str, Any],
    ) -> None:
        """Fill SB3's per-environment info of the environments whose episode ended, and restart their sums."""
        final_observations = infos["final_obs"]
        metrics = infos.get(METRICS_KEY, {})
        failed = infos.get("episode", {}).get(FAILED_KEY, np.zeros(self.num_envs, bool))  # a backend may not say
        elapsed = round(time.perf_counter() - self._started, 6)
        for index in finished:
            episode = {
                "r": float(self._returns[index]),
                "l": int(self._lengths[index]),
                "t": elapsed,
                REWARD_TERMS_KEY: {name: float(sums[index]) for name, sums in self._term_sums.items()},
                METRICS_KEY: {name: float(values[index]) for name, values in metrics.items()},
                FAILED_KEY: bool(failed[index]),
            }
            env_infos[index] = episode_info(final_observations[index], terminated[index], truncated[index], episode)
        self._returns[finished] = 0.0
        self._lengths[finished] = 0
        for sums in self._term_sums.values():
            sums[finished] = 0.0

    def close(self) -> None:
        self.env.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        render_frame = getattr(self.env, "render_frame", None)
        if render_frame is None:
            return [None] * self.num_envs
        return [render_frame(index) for index in range(self.num_envs)]
