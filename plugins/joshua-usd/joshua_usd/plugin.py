"""Entry point of joshua-usd: registers the USD model reader, the `usd` backend, the Isaac tasks and their
terms, and `joshua usd`. Imports nothing heavy."""

from __future__ import annotations

from joshua_core import hookimpl
from joshua_core.plugins import Registrar

USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")

ISAAC_TERMS = {
    "base_lin_vel": "linear velocity of the root in its own frame (Isaac's vel_loc)",
    "base_ang_vel": "angular velocity of the root in its own frame, scaled (Isaac's angvel_loc)",
    "yaw_roll": "the root's yaw and roll",
    "angle_to_target": "angle from the root's heading to the walk target",
    "heading_projection": "the root's x axis dotted with the direction to the walk target",
    "heading_reward": "Isaac's move-to-target reward: 1 above a heading projection threshold, else proportional",
    "progress_to_target": "approach to the walk target per second (Isaac's potential-based progress)",
    "energy": "sum of |action x joint velocity x scale| (Isaac's electricity cost)",
}


@hookimpl
def joshua_register_readers(registry: Registrar) -> None:
    for suffix in USD_SUFFIXES:
        registry.add(suffix, "joshua_usd.reader:UsdReader", "OpenUSD stage with UsdPhysics articulations")


@hookimpl
def joshua_register_backends(registry: Registrar) -> None:
    registry.add(
        "usd",
        "joshua_usd.backend:UsdBackend",
        "USD (Isaac) robots and any other model on MuJoCo (mujoco.batch, MJX in JAX) or PhysX (training.usd)",
        env_kinds=("numpy", "jax"),
    )


@hookimpl
def joshua_register_options(registry: Registrar) -> None:
    registry.add("usd", "joshua_usd.options_pb2:usd", "usd backend's environments: physics (MUJOCO or PHYSX)")


@hookimpl
def joshua_register_tasks(registry: Registrar) -> None:
    registry.add(
        "isaac_ant_locomotion",
        "joshua_usd.tasks.specs:ISAAC_ANT_LOCOMOTION",
        "Ant runs towards a far target: Isaac's Ant observation, rewards and termination",
    )
    registry.add(
        "isaac_trileg", "joshua_usd.tasks.specs:ISAAC_TRILEG", "Trileg balances and walks, in Isaac's locomotion form"
    )


@hookimpl
def joshua_register_terms(registry: Registrar) -> None:
    for name, summary in ISAAC_TERMS.items():
        registry.add(name, f"joshua_usd.tasks.terms:{name}", summary)


@hookimpl
def joshua_register_commands(registry: Registrar) -> None:
    registry.add("usd", "joshua_usd.cli:UsdCommand", "inspect a USD robot, or export an MJCF model to USD for Isaac")
