"""The off-policy trainers' settings (`td3`, `sac`): one frozen dataclass whose defaults are theirs (their only
home, docs/training-offpolicy.md says why each), filled from a TrainingConfig and checked before anything is built:
the settings of the `offpolicy` option, which the run resolves once (`RunContext.settings`).

The defaults follow FastTD3's recipe for thousands of GPU environments (Seo et al. 2025): large minibatches drawn
from a replay buffer kept on the device, n-step returns, clipped double Q, several updates per environment step,
fast target networks (tau 0.1) and observation normalisation.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.runs import checkpoint_interval
from joshua_ppo import options_pb2
from joshua_ppo.config_settings import DEFAULT_TOTAL_TIMESTEPS, pixel_settings, run_settings, set_fields
from joshua_ppo.networks import ACTIVATIONS
from joshua_ppo.settings import PixelSettings, RunSettings

ALGORITHMS = ("td3", "sac")
OPTIONS = "training.offpolicy"


@dataclass(frozen=True)
class OffPolicySettings:
    """Everything a TD3 or SAC run is made of but its environments."""

    algorithm: str  # "td3" or "sac": the trainer's name
    total_timesteps: int = DEFAULT_TOTAL_TIMESTEPS
    checkpoint_interval: int = 0
    seed: int = 0
    steps_per_iteration: int = 8  # steps of every environment per compiled iteration (training.num_steps)
    replay_steps: int = 256  # steps of each environment the replay buffer keeps
    batch_size: int = 32768  # transitions per gradient step, all devices together (training.minibatch_size)
    updates_per_step: int = 2
    learning_starts: int = 8  # steps of each environment before the first update
    n_step: int = 3
    gamma: float = 0.99
    tau: float = 0.1
    actor_learning_rate: float = 3e-4
    critic_learning_rate: float = 3e-4
    max_grad_norm: float | None = None
    actor_hidden_sizes: tuple[int, ...] = (512, 256, 128)
    critic_hidden_sizes: tuple[int, ...] = (1024, 512, 256)
    activation: str = "relu"
    normalize_observations: bool = True
    reward_scaling: float = 1.0
    policy_delay: int = 2  # td3
    exploration_std: tuple[float, float] = (0.001, 0.4)  # td3: each environment's noise std is drawn between these
    target_noise: float = 0.001  # td3
    target_noise_clip: float = 0.5  # td3
    initial_alpha: float = 0.01  # sac
    target_entropy_scale: float = -0.5  # sac: the target entropy is this x the action size
    pixels: PixelSettings | None = None  # set: the actor sees camera images, the critics the flat state
    image_shift: int = 4  # pixels: random-shift augmentation of every image in every update (0: none)
    run: RunSettings = RunSettings()  # the run folder, videos and the live viewer

    @property
    def squash_actions(self) -> bool:
        """Both actors squash: the environment gets actions in [-1, 1] (the exported policy ends in tanh)."""
        return True


def offpolicy_settings(options: options_pb2.OffPolicyOptions, config: TrainingConfig) -> OffPolicySettings:
    """The settings of `config` and its `offpolicy` options for the algorithm `config.trainer` names (the settings
    function the plugin registers with them); a value out of its range is a ConfigError naming its field."""
    algorithm = config.trainer
    if algorithm not in ALGORITHMS:
        raise ConfigError(f"training.offpolicy is for the trainers {', '.join(ALGORITHMS)}, not '{algorithm}'")
    for name in ("num_steps", "minibatch_size", "total_timesteps"):
        if getattr(config, name) < 0:
            raise ConfigError(f"training.{name} must not be negative, got {getattr(config, name)}")
    if config.learning_rate < 0:
        raise ConfigError(f"training.learning_rate must not be negative, got {config.learning_rate}")
    if not 0 <= config.gamma <= 1:
        raise ConfigError(f"training.gamma must be between 0 and 1, got {config.gamma}")
    for name in ("replay_steps", "updates_per_step", "learning_starts", "n_step", "policy_delay", "video_steps"):
        if getattr(options, name) < 0:
            raise ConfigError(f"{OPTIONS}.{name} must not be negative, got {getattr(options, name)}")
    for name in ("tau", "critic_learning_rate", "reward_scaling", "exploration_std_min", "exploration_std_max",
                 "target_noise", "target_noise_clip", "initial_alpha"):  # fmt: skip
        if getattr(options, name) < 0:
            raise ConfigError(f"{OPTIONS}.{name} must not be negative, got {getattr(options, name)}")
    if options.tau > 1:
        raise ConfigError(f"{OPTIONS}.tau must be at most 1, got {options.tau}")
    for name in ("actor_hidden_sizes", "critic_hidden_sizes"):
        if any(size <= 0 for size in getattr(options, name)):
            raise ConfigError(f"{OPTIONS}.{name} must be positive, got {list(getattr(options, name))}")
    total = config.total_timesteps or DEFAULT_TOTAL_TIMESTEPS
    defaults = OffPolicySettings(algorithm)
    std = (
        options.exploration_std_min or defaults.exploration_std[0],
        options.exploration_std_max or defaults.exploration_std[1],
    )
    if std[0] > std[1]:
        raise ConfigError(f"{OPTIONS}.exploration_std_min {std[0]} is above exploration_std_max {std[1]}")
    learning_rate = config.learning_rate or defaults.actor_learning_rate
    given: dict[str, Any] = set_fields(
        steps_per_iteration=config.num_steps,
        batch_size=config.minibatch_size,
        gamma=config.gamma,
        replay_steps=options.replay_steps,
        updates_per_step=options.updates_per_step,
        learning_starts=options.learning_starts,
        n_step=options.n_step,
        tau=options.tau,
        actor_hidden_sizes=tuple(options.actor_hidden_sizes),
        critic_hidden_sizes=tuple(options.critic_hidden_sizes),
        reward_scaling=options.reward_scaling,
        policy_delay=options.policy_delay,
        target_noise=options.target_noise,
        target_noise_clip=options.target_noise_clip,
        initial_alpha=options.initial_alpha,
        target_entropy_scale=options.target_entropy_scale,
    )
    settings = OffPolicySettings(
        algorithm,
        total_timesteps=total,
        checkpoint_interval=checkpoint_interval(config.checkpoint_interval, total),
        seed=int(config.seed),
        actor_learning_rate=learning_rate,
        critic_learning_rate=options.critic_learning_rate or learning_rate,
        max_grad_norm=options.max_grad_norm if options.max_grad_norm > 0 else None,
        normalize_observations=not config.disable_normalization,
        exploration_std=std,
        pixels=pixel_settings(options.pixels, OPTIONS) if options.HasField("pixels") else None,
        image_shift=max(options.image_shift, 0) if options.image_shift else defaults.image_shift,
        run=run_settings(config, options),
        **given,
    )
    if settings.learning_starts <= settings.n_step:
        raise ConfigError(
            f"{OPTIONS}.learning_starts {settings.learning_starts} must be more than n_step {settings.n_step}: "
            "an n-step target needs that many steps in the buffer and the one after them"
        )
    if settings.replay_steps < settings.learning_starts:
        raise ConfigError(
            f"{OPTIONS}.replay_steps {settings.replay_steps} must be at least learning_starts "
            f"{settings.learning_starts}: the buffer must hold what is collected before the first update"
        )
    if settings.activation not in ACTIVATIONS:
        raise ConfigError(f"{OPTIONS}.activation is not one of: {', '.join(ACTIVATIONS)}")
    return settings


def check_batch(settings: OffPolicySettings, num_envs: int, devices: int) -> None:
    """The minibatch fits the devices and the replay buffer it is drawn from (`num_envs` environments)."""
    if settings.batch_size % devices:
        raise ConfigError(f"training.minibatch_size {settings.batch_size} must be a multiple of the {devices} devices")
    collected = num_envs * settings.learning_starts
    if settings.batch_size > collected:
        raise ConfigError(
            f"training.minibatch_size {settings.batch_size} is more than the {collected} transitions the buffer holds "
            f"at the first update (num_envs {num_envs} x {OPTIONS}.learning_starts {settings.learning_starts}): "
            "lower it, or raise learning_starts or num_envs"
        )
