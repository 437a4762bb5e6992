"""Entry point of joshua-sb3: registers the `sb3` trainer and its options, with the settings they are read into.
Imports nothing heavy."""

from __future__ import annotations

from joshua_core import hookimpl
from joshua_core.plugins import Registrar


@hookimpl
def joshua_register_trainers(registry: Registrar) -> None:
    registry.add(
        "sb3",
        "joshua_sb3.trainer:Sb3Trainer",
        "stable-baselines3 PPO (SAC, TD3) on NumPy vector environments (the CPU MuJoCo ones)",
        env_kinds=("numpy",),
    )


# The options' fields that moved to TrainingConfig, which every trainer reads: old configs that still write them
# in `sb3 { ... }` are read as the new ones (joshua_core.legacy).
MOVED = {
    name: name
    for name in ("run_name", "resume", "checkpoint_interval", "hidden_sizes", "disable_normalization", "entropy_coef")
}


@hookimpl
def joshua_register_options(registry: Registrar) -> None:
    registry.add(
        "sb3",
        "joshua_sb3.options_pb2:sb3",
        "sb3 trainer: algorithm, checkpoint trust",
        moved=MOVED,
        settings="joshua_sb3.settings:sb3_settings",
    )
