"""JOSHUA's stable-baselines3 trainer (`sb3`): PPO, SAC or TD3 on the batched MuJoCo environments.

The package stays light (the `joshua` entry point imports `joshua_sb3.plugin`); torch and
stable-baselines3 are imported by `joshua_sb3.trainer` and `joshua_sb3.vec_env` when a run uses them.
`SameStepVecEnv` (an SB3 VecEnv over any NUMPY vector environment), its base `BatchVecEnv` and
`episode_info` (SB3's info of an ended episode) are exported for other plugins.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from joshua_sb3.vec_env import BatchVecEnv, SameStepVecEnv, episode_info

__all__ = ["BatchVecEnv", "SameStepVecEnv", "episode_info"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from joshua_sb3 import vec_env

        return getattr(vec_env, name)
    raise AttributeError(f"module 'joshua_sb3' has no attribute '{name}'")
