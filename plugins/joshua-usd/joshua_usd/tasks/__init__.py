"""The Isaac-convention tasks of joshua-usd and their Python API.

`AntEnv(num_envs=1024, device="cuda")` and `TrilegEnv(...)` are stable-baselines3 VecEnvs of the
tasks `isaac_ant_locomotion` and `isaac_trileg` (`joshua_usd.tasks.envs`). This package stays light,
because the plugin's task and term registrations point into it: the names below are imported on
first use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from joshua_usd.tasks.envs import AntEnv, TrilegEnv

__all__ = ["AntEnv", "TrilegEnv"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from joshua_usd.tasks import envs

        return getattr(envs, name)
    raise AttributeError(f"module 'joshua_usd.tasks' has no attribute '{name}'")
