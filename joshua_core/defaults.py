"""What a config means where it leaves a component empty: the default components and the components a config
needs. Policy, not loading: the loader (`joshua_core.config`), the CLI and `RunContext` all read it here, so
the defaults have one home below all of them."""

from __future__ import annotations

from joshua_core.config_pb2 import JoshuaConfig, SimulationConfig, TrainingConfig
from joshua_core.kinds import Kind

# The trainer and backend a training job uses when the config leaves them empty (each independently of the other).
DEFAULT_TRAINER = "ppo"
DEFAULT_TRAINING_BACKEND = "mjx"
# Environments in a NUMPY (CPU) batch when a training config leaves num_envs 0: the default of the trainers and
# helpers that step them (trainers on JAX environments, which batch thousands, keep their own).
DEFAULT_NUMPY_NUM_ENVS = 16
DEFAULT_SIMULATION_BACKEND = "mujoco"
# Where a run writes when its config names no folder (simulation.output_dir, training.checkpoint_dir; see
# docs/configuration.md), relative to the working directory; commands with an output folder default to it too.
DEFAULT_OUTPUT_DIR = "joshua_output"
DEFAULT_MODE = "INTERACTIVE"  # a config that names no mode opens the viewer (docs/configuration.md)


def simulation_mode(simulation: SimulationConfig) -> str:
    """The mode a simulation runs: the one it names, else INTERACTIVE."""
    return simulation.mode or DEFAULT_MODE


def simulation_backend(simulation: SimulationConfig) -> str:
    """The backend a simulation uses: the one it names, else the default."""
    return simulation.backend or DEFAULT_SIMULATION_BACKEND


def simulation_output_dir(simulation: SimulationConfig) -> str:
    """The folder a simulation writes to: the one it names, else DEFAULT_OUTPUT_DIR."""
    return simulation.output_dir or DEFAULT_OUTPUT_DIR


def training_output_dir(training: TrainingConfig) -> str:
    """The folder a training job writes its runs and checkpoints to: `checkpoint_dir`, else DEFAULT_OUTPUT_DIR."""
    return training.checkpoint_dir or DEFAULT_OUTPUT_DIR


def training_plugins(training: TrainingConfig) -> tuple[str, str]:
    """The (trainer, backend) a training job uses: the ones it names, else the defaults."""
    return training.trainer or DEFAULT_TRAINER, training.backend or DEFAULT_TRAINING_BACKEND


def required_components(config: JoshuaConfig) -> list[tuple[Kind, str]]:
    """The plugin components a config needs to run (before or after `joshua_core.config.finalize`)."""
    if config.operation_mode == JoshuaConfig.SIMULATION:
        return [(Kind.MODE, simulation_mode(config.simulation)), (Kind.BACKEND, simulation_backend(config.simulation))]
    trainer, backend = training_plugins(config.training)
    return [(Kind.TRAINER, trainer), (Kind.BACKEND, backend)]
