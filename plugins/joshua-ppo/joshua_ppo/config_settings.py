"""A TrainingConfig's PPO hyper-parameters turned into `train_ppo`'s settings, with the defaults filled in: the settings
of the `ppo` option, which the run resolves once (`RunContext.settings`)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.runs import checkpoint_interval
from joshua_ppo import options_pb2
from joshua_ppo.networks import ACTIVATIONS
from joshua_ppo.options_pb2 import PpoOptions
from joshua_ppo.settings import (
    NetworkSettings,
    OptimizationSettings,
    PixelSettings,
    ReturnSettings,
    RolloutSettings,
    RunSettings,
    TeacherSettings,
)

DEFAULT_TOTAL_TIMESTEPS = 50_000_000
OPTION = "ppo"  # the option these are the settings of


@dataclass(frozen=True)
class PpoSettings:
    """A TrainingConfig's PPO hyper-parameters; a field the config leaves zero or empty takes the settings
    dataclass's default (`joshua_ppo.settings`, their only home; docs/training-mjx.md#ppo-options)."""

    rollout: RolloutSettings
    optimization: OptimizationSettings
    returns: ReturnSettings
    network: NetworkSettings
    total_timesteps: int
    checkpoint_interval: int
    seed: int
    teacher: TeacherSettings | None = None  # loaded with the environments: joshua_ppo.teacher.load_teacher
    run: RunSettings = field(default_factory=RunSettings)

    @property
    def groups(self) -> dict[str, Any]:
        """The four settings groups as the keyword arguments `train_ppo` and `make_iteration` take."""
        return {
            "rollout": self.rollout,
            "optimization": self.optimization,
            "returns": self.returns,
            "network": self.network,
        }


def ppo_settings(options: PpoOptions, config: TrainingConfig) -> PpoSettings:
    """The PPO settings of `config` and its `ppo` options (the settings function the plugin registers with them); a
    value out of its range is a ConfigError naming its field."""
    for owner, name in ((config, "training.hidden_sizes"), (options, "training.ppo.value_hidden_sizes")):
        sizes = list(getattr(owner, name.rpartition(".")[2]))
        if any(size <= 0 for size in sizes):
            raise ConfigError(f"{name} must be positive, got {sizes}")
    for name in ("desired_kl", "max_kl"):
        if getattr(options, name) < 0:
            raise ConfigError(f"training.ppo.{name} must not be negative, got {getattr(options, name)}")
    for name in ("num_steps", "num_epochs", "minibatch_size", "total_timesteps"):  # num_envs: by EnvSpec
        if getattr(config, name) < 0:
            raise ConfigError(f"training.{name} must not be negative")
    total = config.total_timesteps or DEFAULT_TOTAL_TIMESTEPS
    optimization = OptimizationSettings(
        **set_fields(
            num_epochs=config.num_epochs,
            minibatch_size=config.minibatch_size,
            learning_rate=config.learning_rate,
            clip_epsilon=config.clip_epsilon,
            value_coef=options.value_coef,
            max_grad_norm=options.max_grad_norm,
        ),
        entropy_coef=config.entropy_coef,
        desired_kl=options.desired_kl,
        max_kl=options.max_kl,
        anneal_steps=total if options.anneal_learning_rate else 0,
    )
    if optimization.max_grad_norm is not None and optimization.max_grad_norm < 0:  # negative: no clipping
        optimization = replace(optimization, max_grad_norm=None)
    network = NetworkSettings(
        **set_fields(hidden_sizes=tuple(config.hidden_sizes), activation=options.activation),
        value_hidden_sizes=tuple(options.value_hidden_sizes),
        normalize_observations=not config.disable_normalization,
        squash_actions=options.squash_actions,
        state_dependent_std=options.state_dependent_std,
        pixels=pixel_settings(options.pixels) if options.HasField("pixels") else None,
    )
    if network.activation not in ACTIVATIONS:
        raise ConfigError(f"training.ppo.activation '{options.activation}' is not one of: {', '.join(ACTIVATIONS)}")
    return PpoSettings(
        rollout=RolloutSettings(
            **set_fields(num_steps=config.num_steps, unrolls_per_iteration=options.unrolls_per_iteration)
        ),
        optimization=optimization,
        returns=ReturnSettings(
            **set_fields(gamma=config.gamma, gae_lambda=config.gae_lambda, reward_scaling=options.reward_scaling),
            recompute_advantages=options.recompute_advantages,
            advantage=PpoOptions.Advantage.Name(options.advantage).lower(),
        ),
        network=network,
        total_timesteps=total,
        checkpoint_interval=checkpoint_interval(config.checkpoint_interval, total),
        seed=int(config.seed),
        teacher=_teacher_settings(options.teacher) if options.HasField("teacher") else None,
        run=run_settings(config, options),
    )


def run_settings(config: TrainingConfig, options: options_pb2.PpoOptions | options_pb2.OffPolicyOptions) -> RunSettings:
    """The run settings of a JAX trainer: the run folder from `config`, videos and the viewer from its `options`."""
    return RunSettings(
        name=config.run_name,
        resume=config.resume,
        video_interval=options.video_interval,
        **set_fields(video_steps=options.video_steps, viewer_envs=options.viewer_envs),
        viewer=PpoOptions.Viewer.Name(options.viewer).lower(),
    )


def _teacher_settings(options: options_pb2.Teacher) -> TeacherSettings:
    """The teacher's settings, checked: a run named, a weight that is not negative (0: the default)."""
    if not options.run:
        raise ConfigError("training.ppo.teacher.run must name the teacher's run folder or checkpoint folder")
    if options.weight < 0:
        raise ConfigError(f"training.ppo.teacher.weight must not be negative, got {options.weight}")
    return TeacherSettings(options.run, **set_fields(weight=options.weight))


def pixel_settings(options: options_pb2.PixelOptions, owner: str = "training.ppo") -> PixelSettings:
    """The pixel policy's settings of the trainer options at `owner`, checked: cameras named, one kernel size and
    stride per conv layer, sizes
    positive (which cameras the task has is checked where the network meets the environments)."""
    if not options.cameras:
        raise ConfigError(f"{owner}.pixels.cameras must name at least one of the task's cameras (task_config.cameras)")
    pixels = PixelSettings(
        cameras=tuple(options.cameras),
        observation_terms=tuple(options.observation_terms),
        commands=tuple(options.commands),
        **set_fields(
            channels=tuple(options.channels),
            kernel_sizes=tuple(options.kernel_sizes),
            strides=tuple(options.strides),
            feature_size=options.feature_size,
        ),
    )
    layers = {len(pixels.channels), len(pixels.kernel_sizes), len(pixels.strides)}
    if len(layers) != 1:
        raise ConfigError(
            f"{owner}.pixels: channels, kernel_sizes and strides must have one entry per conv layer, got "
            f"{list(pixels.channels)}, {list(pixels.kernel_sizes)}, {list(pixels.strides)}"
        )
    for name in ("channels", "kernel_sizes", "strides"):
        if any(size <= 0 for size in getattr(pixels, name)):
            raise ConfigError(f"{owner}.pixels.{name} must be positive, got {list(getattr(pixels, name))}")
    if pixels.feature_size < 0:
        raise ConfigError(f"{owner}.pixels.feature_size must be positive, got {pixels.feature_size}")
    return pixels


def set_fields(**values: Any) -> dict[str, Any]:
    """The values a config sets. An unset proto3 number or list reads as zero or empty, which means "the
    default" (docs/configuration.md): those are left out, so the settings dataclasses supply them."""
    return {name: value for name, value in values.items() if value}
