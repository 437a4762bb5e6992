"""PPO's settings in four groups (rollout, optimisation, returns, network) and the check of their batch arithmetic.

Plain frozen dataclasses whose defaults are PPO's (their only home, documented in
docs/training-mjx.md#ppo-options); `joshua_ppo.config_settings` fills them from a TrainingConfig, leaving to
them every field the config leaves zero.
"""

from __future__ import annotations

from dataclasses import dataclass

from joshua_core.errors import ConfigError

OBSERVATION_CLIP = 10.0  # normalised observations are clipped to +-this
LEARNING_RATE_BOUNDS = (1e-5, 1e-2)  # of the adaptive learning rate
ADVANTAGE_ESTIMATORS = ("gae", "lambda_return")  # ReturnSettings.advantage


@dataclass(frozen=True)
class RunSettings:
    """A JAX trainer's run besides its algorithm: which run folder (training.run_name, resume), and what it shows and
    records besides checkpoints (its options' videos and live viewer)."""

    name: str = ""  # empty: a new run named after the task and the time
    resume: bool = False  # continue the run `name` (empty: the trainer's newest) from its newest checkpoint
    video_interval: int = 0  # iterations between rollout videos; 0: at every checkpoint; negative: never
    video_steps: int = 0  # environment steps of each video; 0: one episode
    viewer: str = "auto"  # the live MuJoCo viewer: "auto" (when a display is usable), "off" or "on" (required)
    viewer_envs: int = 4  # environments the live viewer draws over each other


@dataclass(frozen=True)
class RolloutSettings:
    """How much experience one iteration collects: num_envs x num_steps x unrolls_per_iteration transitions,
    where num_envs is the environments' own (`env.num_envs`)."""

    num_steps: int = 10  # unroll length: steps per environment between bootstraps
    unrolls_per_iteration: int = 1


@dataclass(frozen=True)
class OptimizationSettings:
    """The PPO update."""

    num_epochs: int = 4
    minibatch_size: int = 256  # transitions per gradient step (all devices together)
    learning_rate: float = 3e-4
    clip_epsilon: float = 0.2
    entropy_coef: float = 0.0
    value_coef: float = 0.5
    max_grad_norm: float | None = 1.0
    # > 0: adapt the learning rate on every gradient step to keep the policy's KL divergence from the
    # collecting policy near this (see adapt_learning_rate); 0: a constant learning rate
    desired_kl: float = 0.0
    # > 0: the iteration's remaining gradient steps are skipped once a minibatch's approximate KL divergence
    # from the collecting policy exceeds this, so one runaway update cannot carry the policy far; 0: never
    max_kl: float = 0.0
    # > 0: the learning rate falls linearly from learning_rate to 0 over this many environment steps
    # (counted from the run's start, so across resumes); 0: no annealing
    anneal_steps: int = 0

    @property
    def watches_kl(self) -> bool:
        """Whether the update measures its KL divergence from the collecting policy (desired_kl or max_kl)."""
        return self.desired_kl > 0 or self.max_kl > 0


@dataclass(frozen=True)
class ReturnSettings:
    """Returns and advantages."""

    gamma: float = 0.99
    gae_lambda: float = 0.95
    reward_scaling: float = 1.0  # rewards are multiplied by this for learning; reported returns are unscaled
    # GAE and value targets recomputed on every minibatch with the current value network (as Brax does),
    # rather than once per iteration with the network that collected the data
    recompute_advantages: bool = False
    # "gae": sum over k of (gamma lambda)^k TD errors (Schulman et al.); "lambda_return": the TD error
    # towards the next step's lambda-return, r + gamma G_{t+1} - V(s_t) (Brax's PPO), which weighs the
    # next step's advantage by gamma rather than gamma lambda
    advantage: str = "gae"


@dataclass(frozen=True)
class PixelSettings:
    """A policy that sees camera images through a CNN encoder per camera (conv layers with ReLU and SAME padding,
    then a dense layer of feature_size), beside some of the flat observation; defaults: the Nature-CNN encoder
    (Mnih et al. 2015), as MuJoCo Playground's vision PPO uses."""

    cameras: tuple[str, ...]  # the task's cameras (rgb or depth) the policy sees
    observation_terms: tuple[str, ...] = ()  # the observation terms it sees beside them; empty: all of them
    commands: tuple[str, ...] = ()  # the task's commands it is given (e.g. the goal the images do not show)
    channels: tuple[int, ...] = (32, 64, 64)  # of each conv layer
    kernel_sizes: tuple[int, ...] = (8, 4, 3)
    strides: tuple[int, ...] = (4, 2, 1)
    feature_size: int = 256  # features of each camera's encoder


@dataclass(frozen=True)
class TeacherSettings:
    """A trained policy of the same task that sees the flat observation, which the policy imitates beside its PPO
    loss: each minibatch adds `weight` x the KL divergence from the teacher's action distribution to the policy's,
    on the policy's own rollouts (on-policy distillation, as in Kickstarting, Schmitt et al. 2018, and DAgger).
    A pixel policy learns from it where the reward alone reaches it slowly (docs/training-mjx.md#pixel-policies)."""

    run: str  # its run folder (its newest checkpoint) or a checkpoint folder
    weight: float = 1.0


@dataclass(frozen=True)
class NetworkSettings:
    """The actor-critic network, its input and its output."""

    hidden_sizes: tuple[int, ...] = (256, 256)  # the shared trunk; the policy's layers when value_hidden_sizes is set
    value_hidden_sizes: tuple[int, ...] = ()  # set: a separate value network of these layers
    normalize_observations: bool = True
    squash_actions: bool = False  # tanh of the Gaussian sample goes to the env, rather than the sample clipped
    activation: str = "relu"  # of the hidden layers: a name in joshua_ppo.networks.ACTIVATIONS
    state_dependent_std: bool = False  # the policy network outputs the std too, rather than one learned vector
    pixels: PixelSettings | None = None  # set: the policy sees camera images (the value network the flat state)

    @property
    def separate_value_network(self) -> bool:
        """Whether the value network is its own (and sees the observation without its noise): a pixel policy's
        always is, as the value network keeps the flat state."""
        return bool(self.value_hidden_sizes) or self.pixels is not None


def check_settings(
    rollout: RolloutSettings,
    optimization: OptimizationSettings,
    num_envs: int,
    devices: int,
    whole_unrolls: bool = False,
) -> int:
    """Validate the batch arithmetic of `num_envs` environments (checked where they are made) on `devices`
    and the learning-rate options; returns the number of minibatches per epoch.

    whole_unrolls: minibatches are made of whole unrolls (for recomputing advantages), not single steps.
    """
    for name, value in (
        ("num_steps", rollout.num_steps),
        ("unrolls_per_iteration", rollout.unrolls_per_iteration),
        ("num_epochs", optimization.num_epochs),
        ("minibatch_size", optimization.minibatch_size),
    ):
        if value < 1:
            raise ConfigError(f"PPO setting {name} must be at least 1, got {value}")
    batch = num_envs * rollout.num_steps * rollout.unrolls_per_iteration
    if batch % optimization.minibatch_size:
        raise ConfigError(
            f"minibatch_size {optimization.minibatch_size} must divide the iteration's "
            f"num_envs x num_steps x unrolls_per_iteration = {batch} transitions"
        )
    if optimization.minibatch_size % devices:
        raise ConfigError(f"minibatch_size {optimization.minibatch_size} must be a multiple of the {devices} devices")
    if optimization.desired_kl > 0 and optimization.anneal_steps > 0:
        raise ConfigError(
            "desired_kl and an annealed learning rate cannot be combined (both set the learning rate): "
            "drop ppo.desired_kl or ppo.anneal_learning_rate (anneal_steps)"
        )
    if whole_unrolls and optimization.minibatch_size % (devices * rollout.num_steps):
        raise ConfigError(
            f"with recompute_advantages, minibatch_size {optimization.minibatch_size} must be a multiple of "
            f"num_steps x devices = {rollout.num_steps * devices} (minibatches are made of whole unrolls)"
        )
    return batch // optimization.minibatch_size


def check_advantage(returns: ReturnSettings) -> None:
    """The advantage estimator is one PPO knows."""
    if returns.advantage not in ADVANTAGE_ESTIMATORS:
        raise ConfigError(f"advantage '{returns.advantage}' is not one of: {', '.join(ADVANTAGE_ESTIMATORS)}")
