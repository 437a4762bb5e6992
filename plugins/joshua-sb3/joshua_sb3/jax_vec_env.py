"""`JaxVecEnv`: a stable-baselines3 VecEnv over JAX environments (EnvKind.JAX, e.g. joshua-mjx's MjxEnv).

The environments stay on their JAX devices; each SB3 step is one jitted `step` of the whole batch,
with numpy actions in and numpy observations, rewards and dones out. Autoreset is the environment's
own (same step); this adapter reports it the way SB3 expects: where an episode ended, the returned
observation is the next episode's first, and `infos[i]` holds `terminal_observation`,
`TimeLimit.truncated` and `episode` (return `r`, length `l`, time `t`, per-term reward sums and the
task's metrics). After a step that ended episodes it draws fresh start states (`redraw_starts`), so
every episode starts from its own draw of the task's reset terms.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np
from numpy.typing import NDArray
from stable_baselines3.common.vec_env.base_vec_env import VecEnvObs, VecEnvStepReturn

from joshua_sb3.vec_env import FAILED_KEY, BatchVecEnv, episode_info


class JaxVecEnv(BatchVecEnv):
    """SB3 view of a batched JAX environment (`reset(key)`, `step(state, action)`, `redraw_starts(state)`)."""

    def __init__(self, env: Any, seed: int = 0) -> None:
        self.env = env
        observation_space = gymnasium.spaces.Box(-np.inf, np.inf, (env.observation_size,), np.float32)
        action_space = gymnasium.spaces.Box(-1.0, 1.0, (env.action_size,), np.float32)
        super().__init__(env.num_envs, observation_space, action_space)
        self._next_seed = seed
        self._state: Any = None
        self._actions: NDArray[Any] | None = None
        self._started = time.perf_counter()

    def reset(self) -> VecEnvObs:
        """Every environment at a new episode; the seed given to `seed()` (else the next of the constructor's)."""
        seed = self._seeds[0] if self._seeds[0] is not None else self._next_seed
        self._next_seed = seed + 1
        self._state = self.env.reset(jax.random.PRNGKey(seed))
        self._reset_seeds()
        return np.array(self._state.observation)

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None or self._state is None:
            raise RuntimeError("step_wait() needs reset() and step_async() first")
        state = self.env.step(self._state, jnp.asarray(self._actions, jnp.float32))
        self._actions = None
        observation, reward, terminated, truncated = jax.device_get(
            (state.observation, state.reward, state.terminated, state.truncated)
        )
        dones = np.logical_or(terminated, truncated)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        if dones.any():
            self._finish_episodes(state, np.flatnonzero(dones), infos, terminated, truncated)
            state = self.env.redraw_starts(state)
        self._state = state
        # copies: device_get gives read-only arrays, and SB3 writes into rewards (bootstrapping truncations)
        return np.array(observation), np.array(reward, np.float32), dones, infos

    def _finish_episodes(
        self,
        state: Any,
        finished: NDArray[np.intp],
        infos: list[dict[str, Any]],
        terminated: NDArray[np.bool_],
        truncated: NDArray[np.bool_],
    ) -> None:
        """SB3's per-environment infos of the environments whose episode ended on this step."""
        final_observation, episode = jax.device_get((state.final_observation, state.episode))
        elapsed = round(time.perf_counter() - self._started, 6)
        for index in finished:
            record = {
                "r": float(episode.return_[index]),
                "l": int(episode.length[index]),
                "t": elapsed,
                "reward_terms": {name: float(sums[index]) for name, sums in episode.reward_terms.items()},
                "metrics": {name: float(values[index]) for name, values in episode.metrics.items()},
                FAILED_KEY: bool(episode.failed[index]),
            }
            infos[index] = episode_info(final_observation[index], terminated[index], truncated[index], record)

    def close(self) -> None:
        self._state = None

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None] * self.num_envs
