"""The SB3 trainer's settings: a TrainingConfig with every zero replaced by the trainer's default, the settings of the
`sb3` option, which the run resolves once (`RunContext.settings`)."""

from __future__ import annotations

import sys
from dataclasses import asdict, dataclass
from typing import Any

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.defaults import DEFAULT_NUMPY_NUM_ENVS
from joshua_core.errors import ConfigError
from joshua_core.limits import check_one_iteration
from joshua_core.runs import checkpoint_interval
from joshua_sb3 import options_pb2

OPTION = "sb3"  # the option these are the settings of
ALGORITHMS = ("PPO", "SAC", "TD3")
ON_POLICY_ONLY = ("gae_lambda", "clip_epsilon")  # PPO fields SAC and TD3 have no use for
DEFAULT_TOTAL_TIMESTEPS = 1_000_000
DEFAULT_HIDDEN_SIZES = (256, 256)
DEFAULT_REPLAY_BUFFER_SIZE = 1_000_000  # SB3's default, transitions of all environments together


@dataclass(frozen=True)
class Settings:
    """Resolved hyper-parameters and the run's folder options; `num_steps` and `num_epochs` mean per-env rollout
    length and epochs for PPO, steps between updates (train_freq) and gradient steps per update for SAC/TD3. The
    number of environments is not among them: the environments hold it."""

    algorithm: str
    total_timesteps: int
    checkpoint_interval: int
    num_steps: int
    num_epochs: int
    minibatch_size: int
    learning_rate: float
    gamma: float
    gae_lambda: float
    clip_epsilon: float
    entropy_coef: float
    hidden_sizes: tuple[int, ...]
    normalize: bool
    seed: int
    run_name: str = ""  # empty: a new run named after the task, the algorithm and the time
    resume: bool = False  # continue the run `run_name` (empty: the newest sb3 run) from its last checkpoint
    trust_checkpoint: bool = False  # resume from a run folder this machine's user did not write

    def algorithm_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of the SB3 algorithm's constructor (besides policy, env, seed, device)."""
        common: dict[str, Any] = {
            "learning_rate": self.learning_rate,
            "gamma": self.gamma,
            "batch_size": self.minibatch_size,
            "policy_kwargs": {"net_arch": list(self.hidden_sizes)},
        }
        if self.algorithm == "PPO":
            return common | {
                "n_steps": self.num_steps,
                "n_epochs": self.num_epochs,
                "gae_lambda": self.gae_lambda,
                "clip_range": self.clip_epsilon,
                "ent_coef": self.entropy_coef,
            }
        # A replay buffer larger than the run is preallocated (and checkpointed) memory that is never used.
        buffer_size = min(DEFAULT_REPLAY_BUFFER_SIZE, self.total_timesteps)
        return common | {"train_freq": self.num_steps, "gradient_steps": self.num_epochs, "buffer_size": buffer_size}

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def sb3_settings(options: options_pb2.Sb3Options, config: TrainingConfig) -> Settings:
    """The settings of `config` and its `sb3` options (the settings function the plugin registers with them); a value
    out of its range is a ConfigError naming its field."""
    algorithm = (options.algorithm or "PPO").upper()
    if algorithm not in ALGORITHMS:
        raise ConfigError(f"training.sb3.algorithm '{options.algorithm}' is unknown; choose one of {ALGORITHMS}")
    on_policy = algorithm == "PPO"
    if not on_policy:
        ignored = [name for name in ON_POLICY_ONLY if getattr(config, name)]
        if ignored:
            names = ", ".join(f"training.{name}" for name in ignored)
            print(f"joshua: warning: {algorithm} ignores {names} (PPO settings)", file=sys.stderr)
    if any(size <= 0 for size in config.hidden_sizes):
        raise ConfigError(f"training.hidden_sizes must be positive, got {list(config.hidden_sizes)}")
    if config.checkpoint_interval < 0:
        raise ConfigError("training.checkpoint_interval must not be negative")
    total_timesteps = config.total_timesteps or DEFAULT_TOTAL_TIMESTEPS
    num_steps = config.num_steps or (64 if on_policy else 1)
    # SB3 collects num_steps per environment (PPO's n_steps, SAC's and TD3's train_freq) before it checks the total
    check_one_iteration(total_timesteps, config.num_envs or DEFAULT_NUMPY_NUM_ENVS, num_steps)
    return Settings(
        algorithm=algorithm,
        total_timesteps=total_timesteps,
        checkpoint_interval=checkpoint_interval(config.checkpoint_interval, total_timesteps),
        num_steps=num_steps,
        num_epochs=config.num_epochs or (10 if on_policy else 1),
        minibatch_size=config.minibatch_size or 256,
        learning_rate=config.learning_rate or 3e-4,
        gamma=config.gamma or 0.99,
        gae_lambda=config.gae_lambda or 0.95,
        clip_epsilon=config.clip_epsilon or 0.2,
        entropy_coef=config.entropy_coef,
        hidden_sizes=tuple(config.hidden_sizes) or DEFAULT_HIDDEN_SIZES,
        normalize=not config.disable_normalization,
        seed=int(config.seed),
        run_name=config.run_name,
        resume=config.resume,
        trust_checkpoint=options.trust_checkpoint,
    )
