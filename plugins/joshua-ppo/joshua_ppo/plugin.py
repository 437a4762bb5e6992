"""Entry point of joshua-ppo: registers the JAX trainers `ppo`, `td3` and `sac` and their options, each with the
settings it is read into. Imports nothing heavy (no jax or flax)."""

from __future__ import annotations

from joshua_core import hookimpl
from joshua_core.plugins import Registrar


@hookimpl
def joshua_register_trainers(registry: Registrar) -> None:
    registry.add(
        "ppo",
        "joshua_ppo.trainer:PpoTrainer",
        "PPO in JAX/Flax on JAX environments (MJX): thousands of environments per GPU",
        env_kinds=("jax",),
    )
    registry.add(
        "td3",
        "joshua_ppo.offpolicy_trainer:Td3Trainer",
        "TD3 in JAX (FastTD3's recipe) on JAX environments: replay on the device, n-step clipped double Q",
        env_kinds=("jax",),
    )
    registry.add(
        "sac",
        "joshua_ppo.offpolicy_trainer:SacTrainer",
        "SAC in JAX on JAX environments: replay on the device, n-step clipped double Q, learned temperature",
        env_kinds=("jax",),
    )


# The options' fields that moved to TrainingConfig, which every trainer reads: old configs that still write them
# in `ppo { ... }` or `offpolicy { ... }` are read as the new ones (joshua_core.legacy).
_SHARED = {"run_name": "run_name", "resume": "resume", "checkpoint_interval": "checkpoint_interval"}
_NORMALIZATION = {"disable_observation_normalization": "disable_normalization"}
PPO_MOVED = _SHARED | _NORMALIZATION | {"hidden_sizes": "hidden_sizes", "entropy_coef": "entropy_coef"}
OFFPOLICY_MOVED = _SHARED | _NORMALIZATION


@hookimpl
def joshua_register_options(registry: Registrar) -> None:
    registry.add(
        "ppo",
        "joshua_ppo.options_pb2:ppo",
        "ppo trainer: network, advantages, schedule, videos",
        moved=PPO_MOVED,
        settings="joshua_ppo.config_settings:ppo_settings",
    )
    registry.add(
        "offpolicy",
        "joshua_ppo.options_pb2:offpolicy",
        "td3 and sac trainers: replay, updates, networks",
        moved=OFFPOLICY_MOVED,
        settings="joshua_ppo.offpolicy_settings:offpolicy_settings",
    )
