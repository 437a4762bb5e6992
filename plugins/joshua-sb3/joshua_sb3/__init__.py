"""JOSHUA's stable-baselines3 trainer (`sb3`): PPO, SAC or TD3 on the batched MuJoCo environments.

The package stays light (the `joshua` entry point imports `joshua_sb3.plugin`); torch and
stable-baselines3 are imported by `joshua_sb3.trainer` and the adapters when a run uses them.
Exported for users and other plugins: `SameStepVecEnv` (an SB3 VecEnv over any NUMPY vector
environment), `JaxVecEnv` (one over JAX environments), their base `BatchVecEnv`, `episode_info`
(SB3's info of an ended episode), and `task_vec_env` (a registered task's environments as an SB3 VecEnv,
`joshua_sb3.task_envs`). A task's alias (`TaskSpec.aliases`, e.g. `AntEnv`) is a name of this package too: the
task as a VecEnv factory (`task_envs.alias_env`), found among the installed tasks when it is first used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from joshua_sb3.jax_vec_env import JaxVecEnv
    from joshua_sb3.task_envs import task_vec_env
    from joshua_sb3.vec_env import BatchVecEnv, SameStepVecEnv, episode_info

__all__ = [
    "BatchVecEnv",
    "JaxVecEnv",
    "SameStepVecEnv",
    "episode_info",
    "task_vec_env",
]


# Searched in this order, so that jax is imported only for JaxVecEnv.
_MODULES = ("vec_env", "task_envs", "jax_vec_env")


def __getattr__(name: str) -> Any:
    if name in __all__:
        from importlib import import_module

        for module in _MODULES:
            exported = import_module(f"joshua_sb3.{module}")
            if hasattr(exported, name):
                return getattr(exported, name)
    if name[:1].isupper() and name.endswith("Env"):  # a task's alias, such as AntEnv
        from joshua_sb3.task_envs import alias_env

        return alias_env(name)
    raise AttributeError(f"module 'joshua_sb3' has no attribute '{name}'")
