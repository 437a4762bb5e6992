"""Entry point of joshua-ppo: registers the `ppo` trainer and its options. Imports nothing heavy (no jax or flax)."""

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


@hookimpl
def joshua_register_options(registry: Registrar) -> None:
    registry.add("ppo", "joshua_ppo.options_pb2:ppo", "ppo trainer: network, advantages, schedule, run, videos")
