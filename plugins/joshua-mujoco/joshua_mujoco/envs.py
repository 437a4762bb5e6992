"""Single Gymnasium environments for the registered tasks, and their registration with Gymnasium.

Importing this module registers one id per task that the installed plugins register (`env_id`:
`joshua/AntLocomotion-v0`, ..., the Isaac tasks of joshua-usd included), each with a vector entry
point (`gymnasium.make_vec(..., vectorization_mode="vector_entry_point")` gives a BatchedVectorEnv).
Gymnasium 1.x loads no plugins by itself (its entry-point plugin system ended with 0.29), so without
importing this module first, `gymnasium.make("joshua_mujoco.envs:joshua/AntLocomotion-v0")`
imports and registers in one go.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from numpy.typing import NDArray

from joshua_core.interfaces import DEFAULT_RENDER_HEIGHT, DEFAULT_RENDER_WIDTH
from joshua_core.kinds import Kind
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_core.tasks import EpisodeSums, account_step
from joshua_core.tasks.task import load_task_spec
from joshua_mujoco.task_options import task_config_from_options
from joshua_mujoco.vector import (
    BatchedSimulation,
    BatchedVectorEnv,
    load_task_model,
    make_vector_env,
)

ENV_NAMESPACE = "joshua"


def env_id(task: str) -> str:
    """The Gymnasium id of a task: its name in CamelCase in the `joshua` namespace, version 0
    (`so_arm100_reach` -> `joshua/SoArm100Reach-v0`)."""
    return f"{ENV_NAMESPACE}/{''.join(part[:1].upper() + part[1:] for part in task.split('_'))}-v0"


class TaskEnv(gymnasium.Env):
    """One environment of a task (a batch of one simulation); episodes end by termination or truncation
    at the task's episode length, and the caller resets."""

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"]}

    def __init__(
        self,
        task: str,
        *,
        model_path: str | None = None,
        render_mode: str | None = None,
        plugins: PluginHost | None = None,
        **task_options: Any,
    ) -> None:
        path = resolve_data_path(model_path) if model_path else None
        config = task_config_from_options(task_options)
        built, model = load_task_model(task, path, plugins or PluginHost.discover(), config)
        self.simulation = BatchedSimulation(built, model, 1, nthread=1)
        self.task = built
        self.render_mode = render_mode
        self.metadata = {**type(self).metadata, "render_fps": round(1.0 / built.dt)}
        self.observation_space = gymnasium.spaces.Box(-np.inf, np.inf, (built.observation_size,), np.float32)
        self.action_space = gymnasium.spaces.Box(-1.0, 1.0, (built.action_size,), np.float32)

    @property
    def dt(self) -> float:
        """Seconds of simulated time per step (frame skip x timestep), as Gymnasium's MuJoCo envs expose it."""
        return float(self.task.dt)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        super().reset(seed=seed)
        if seed is not None:
            self.simulation.seed(seed)
        observation = self.simulation.reset(np.zeros(1, dtype=np.intp))
        return observation[0].astype(np.float32), {}

    def step(self, action: Any) -> tuple[NDArray[np.float32], float, bool, bool, dict[str, Any]]:
        simulation, task = self.simulation, self.task
        failed = simulation.step(np.asarray(action).reshape(1, -1))
        ctx = simulation.context()
        outcome = account_step(task, ctx, failed, EpisodeSums.zeros(np, task, 1, np.float64), np.float64)
        info = {
            "reward_terms": {name: float(value[0]) for name, value in outcome.reward_terms.items()},
            "metrics": {name: float(value[0]) for name, value in outcome.metrics.items()},
        }
        observation = task.observe(ctx)[0].astype(np.float32)
        return observation, float(outcome.reward[0]), bool(outcome.terminated[0]), bool(outcome.truncated[0]), info

    def render(self) -> NDArray[np.uint8] | None:
        if self.render_mode != "rgb_array":
            return None
        return self.simulation.render(0, None, DEFAULT_RENDER_WIDTH, DEFAULT_RENDER_HEIGHT)

    def close(self) -> None:
        self.simulation.close()


def make_vector(task: str, num_envs: int = 1, **kwargs: Any) -> BatchedVectorEnv:
    """Gymnasium's vector entry point: make_vector_env with Gymnasium's keyword arguments; its
    `max_episode_steps` (the registered episode length, or the caller's) becomes the task's episode length."""
    kwargs.pop("vectorization_mode", None)
    max_episode_steps = kwargs.pop("max_episode_steps", None)
    if max_episode_steps is not None and not {"episode_length", "task_config"} & kwargs.keys():
        kwargs["episode_length"] = max_episode_steps
    return make_vector_env(task, num_envs, **kwargs)


def register_envs(plugins: PluginHost | None = None) -> dict[str, str]:
    """Register every task of the installed plugins with Gymnasium (idempotent) and return {id: task};
    `max_episode_steps` is the task's episode length, so `env.spec` says where episodes are truncated
    (the env truncates there itself too)."""
    host = plugins or PluginHost.discover()
    registered = {}
    for task in host.names(Kind.TASK):
        registered[env_id(task)] = task
        if env_id(task) not in gymnasium.registry:
            gymnasium.register(
                env_id(task),
                entry_point="joshua_mujoco.envs:TaskEnv",
                vector_entry_point="joshua_mujoco.envs:make_vector",
                kwargs={"task": task},
                max_episode_steps=load_task_spec(task, host).episode_length,
            )
    return registered


register_envs()
