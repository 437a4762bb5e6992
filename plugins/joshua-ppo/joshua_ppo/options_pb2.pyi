from joshua_core import config_pb2 as _config_pb2
from google.protobuf.internal import containers as _containers
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from collections.abc import Iterable as _Iterable, Mapping as _Mapping
from typing import ClassVar as _ClassVar, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor
PPO_FIELD_NUMBER: _ClassVar[int]
ppo: _descriptor.FieldDescriptor
OFFPOLICY_FIELD_NUMBER: _ClassVar[int]
offpolicy: _descriptor.FieldDescriptor

class PpoOptions(_message.Message):
    __slots__ = ("value_hidden_sizes", "squash_actions", "activation", "state_dependent_std", "recompute_advantages", "advantage", "reward_scaling", "unrolls_per_iteration", "max_grad_norm", "desired_kl", "max_kl", "anneal_learning_rate", "value_coef", "video_interval", "video_steps", "viewer", "viewer_envs", "distributed", "pixels", "teacher")
    class Advantage(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        GAE: _ClassVar[PpoOptions.Advantage]
        LAMBDA_RETURN: _ClassVar[PpoOptions.Advantage]
    GAE: PpoOptions.Advantage
    LAMBDA_RETURN: PpoOptions.Advantage
    class Viewer(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        AUTO: _ClassVar[PpoOptions.Viewer]
        OFF: _ClassVar[PpoOptions.Viewer]
        ON: _ClassVar[PpoOptions.Viewer]
    AUTO: PpoOptions.Viewer
    OFF: PpoOptions.Viewer
    ON: PpoOptions.Viewer
    VALUE_HIDDEN_SIZES_FIELD_NUMBER: _ClassVar[int]
    SQUASH_ACTIONS_FIELD_NUMBER: _ClassVar[int]
    ACTIVATION_FIELD_NUMBER: _ClassVar[int]
    STATE_DEPENDENT_STD_FIELD_NUMBER: _ClassVar[int]
    RECOMPUTE_ADVANTAGES_FIELD_NUMBER: _ClassVar[int]
    ADVANTAGE_FIELD_NUMBER: _ClassVar[int]
    REWARD_SCALING_FIELD_NUMBER: _ClassVar[int]
    UNROLLS_PER_ITERATION_FIELD_NUMBER: _ClassVar[int]
    MAX_GRAD_NORM_FIELD_NUMBER: _ClassVar[int]
    DESIRED_KL_FIELD_NUMBER: _ClassVar[int]
    MAX_KL_FIELD_NUMBER: _ClassVar[int]
    ANNEAL_LEARNING_RATE_FIELD_NUMBER: _ClassVar[int]
    VALUE_COEF_FIELD_NUMBER: _ClassVar[int]
    VIDEO_INTERVAL_FIELD_NUMBER: _ClassVar[int]
    VIDEO_STEPS_FIELD_NUMBER: _ClassVar[int]
    VIEWER_FIELD_NUMBER: _ClassVar[int]
    VIEWER_ENVS_FIELD_NUMBER: _ClassVar[int]
    DISTRIBUTED_FIELD_NUMBER: _ClassVar[int]
    PIXELS_FIELD_NUMBER: _ClassVar[int]
    TEACHER_FIELD_NUMBER: _ClassVar[int]
    value_hidden_sizes: _containers.RepeatedScalarFieldContainer[int]
    squash_actions: bool
    activation: str
    state_dependent_std: bool
    recompute_advantages: bool
    advantage: PpoOptions.Advantage
    reward_scaling: float
    unrolls_per_iteration: int
    max_grad_norm: float
    desired_kl: float
    max_kl: float
    anneal_learning_rate: bool
    value_coef: float
    video_interval: int
    video_steps: int
    viewer: PpoOptions.Viewer
    viewer_envs: int
    distributed: Distributed
    pixels: PixelOptions
    teacher: Teacher
    def __init__(self, value_hidden_sizes: _Optional[_Iterable[int]] = ..., squash_actions: _Optional[bool] = ..., activation: _Optional[str] = ..., state_dependent_std: _Optional[bool] = ..., recompute_advantages: _Optional[bool] = ..., advantage: _Optional[_Union[PpoOptions.Advantage, str]] = ..., reward_scaling: _Optional[float] = ..., unrolls_per_iteration: _Optional[int] = ..., max_grad_norm: _Optional[float] = ..., desired_kl: _Optional[float] = ..., max_kl: _Optional[float] = ..., anneal_learning_rate: _Optional[bool] = ..., value_coef: _Optional[float] = ..., video_interval: _Optional[int] = ..., video_steps: _Optional[int] = ..., viewer: _Optional[_Union[PpoOptions.Viewer, str]] = ..., viewer_envs: _Optional[int] = ..., distributed: _Optional[_Union[Distributed, _Mapping]] = ..., pixels: _Optional[_Union[PixelOptions, _Mapping]] = ..., teacher: _Optional[_Union[Teacher, _Mapping]] = ...) -> None: ...

class PixelOptions(_message.Message):
    __slots__ = ("cameras", "observation_terms", "commands", "channels", "kernel_sizes", "strides", "feature_size")
    CAMERAS_FIELD_NUMBER: _ClassVar[int]
    OBSERVATION_TERMS_FIELD_NUMBER: _ClassVar[int]
    COMMANDS_FIELD_NUMBER: _ClassVar[int]
    CHANNELS_FIELD_NUMBER: _ClassVar[int]
    KERNEL_SIZES_FIELD_NUMBER: _ClassVar[int]
    STRIDES_FIELD_NUMBER: _ClassVar[int]
    FEATURE_SIZE_FIELD_NUMBER: _ClassVar[int]
    cameras: _containers.RepeatedScalarFieldContainer[str]
    observation_terms: _containers.RepeatedScalarFieldContainer[str]
    commands: _containers.RepeatedScalarFieldContainer[str]
    channels: _containers.RepeatedScalarFieldContainer[int]
    kernel_sizes: _containers.RepeatedScalarFieldContainer[int]
    strides: _containers.RepeatedScalarFieldContainer[int]
    feature_size: int
    def __init__(self, cameras: _Optional[_Iterable[str]] = ..., observation_terms: _Optional[_Iterable[str]] = ..., commands: _Optional[_Iterable[str]] = ..., channels: _Optional[_Iterable[int]] = ..., kernel_sizes: _Optional[_Iterable[int]] = ..., strides: _Optional[_Iterable[int]] = ..., feature_size: _Optional[int] = ...) -> None: ...

class Teacher(_message.Message):
    __slots__ = ("run", "weight")
    RUN_FIELD_NUMBER: _ClassVar[int]
    WEIGHT_FIELD_NUMBER: _ClassVar[int]
    run: str
    weight: float
    def __init__(self, run: _Optional[str] = ..., weight: _Optional[float] = ...) -> None: ...

class Distributed(_message.Message):
    __slots__ = ("coordinator", "num_processes", "process_id")
    COORDINATOR_FIELD_NUMBER: _ClassVar[int]
    NUM_PROCESSES_FIELD_NUMBER: _ClassVar[int]
    PROCESS_ID_FIELD_NUMBER: _ClassVar[int]
    coordinator: str
    num_processes: int
    process_id: int
    def __init__(self, coordinator: _Optional[str] = ..., num_processes: _Optional[int] = ..., process_id: _Optional[int] = ...) -> None: ...

class OffPolicyOptions(_message.Message):
    __slots__ = ("video_interval", "video_steps", "viewer", "viewer_envs", "replay_steps", "updates_per_step", "learning_starts", "n_step", "tau", "critic_learning_rate", "actor_hidden_sizes", "critic_hidden_sizes", "reward_scaling", "max_grad_norm", "policy_delay", "exploration_std_min", "exploration_std_max", "target_noise", "target_noise_clip", "initial_alpha", "target_entropy_scale", "pixels", "image_shift")
    VIDEO_INTERVAL_FIELD_NUMBER: _ClassVar[int]
    VIDEO_STEPS_FIELD_NUMBER: _ClassVar[int]
    VIEWER_FIELD_NUMBER: _ClassVar[int]
    VIEWER_ENVS_FIELD_NUMBER: _ClassVar[int]
    REPLAY_STEPS_FIELD_NUMBER: _ClassVar[int]
    UPDATES_PER_STEP_FIELD_NUMBER: _ClassVar[int]
    LEARNING_STARTS_FIELD_NUMBER: _ClassVar[int]
    N_STEP_FIELD_NUMBER: _ClassVar[int]
    TAU_FIELD_NUMBER: _ClassVar[int]
    CRITIC_LEARNING_RATE_FIELD_NUMBER: _ClassVar[int]
    ACTOR_HIDDEN_SIZES_FIELD_NUMBER: _ClassVar[int]
    CRITIC_HIDDEN_SIZES_FIELD_NUMBER: _ClassVar[int]
    REWARD_SCALING_FIELD_NUMBER: _ClassVar[int]
    MAX_GRAD_NORM_FIELD_NUMBER: _ClassVar[int]
    POLICY_DELAY_FIELD_NUMBER: _ClassVar[int]
    EXPLORATION_STD_MIN_FIELD_NUMBER: _ClassVar[int]
    EXPLORATION_STD_MAX_FIELD_NUMBER: _ClassVar[int]
    TARGET_NOISE_FIELD_NUMBER: _ClassVar[int]
    TARGET_NOISE_CLIP_FIELD_NUMBER: _ClassVar[int]
    INITIAL_ALPHA_FIELD_NUMBER: _ClassVar[int]
    TARGET_ENTROPY_SCALE_FIELD_NUMBER: _ClassVar[int]
    PIXELS_FIELD_NUMBER: _ClassVar[int]
    IMAGE_SHIFT_FIELD_NUMBER: _ClassVar[int]
    video_interval: int
    video_steps: int
    viewer: PpoOptions.Viewer
    viewer_envs: int
    replay_steps: int
    updates_per_step: int
    learning_starts: int
    n_step: int
    tau: float
    critic_learning_rate: float
    actor_hidden_sizes: _containers.RepeatedScalarFieldContainer[int]
    critic_hidden_sizes: _containers.RepeatedScalarFieldContainer[int]
    reward_scaling: float
    max_grad_norm: float
    policy_delay: int
    exploration_std_min: float
    exploration_std_max: float
    target_noise: float
    target_noise_clip: float
    initial_alpha: float
    target_entropy_scale: float
    pixels: PixelOptions
    image_shift: int
    def __init__(self, video_interval: _Optional[int] = ..., video_steps: _Optional[int] = ..., viewer: _Optional[_Union[PpoOptions.Viewer, str]] = ..., viewer_envs: _Optional[int] = ..., replay_steps: _Optional[int] = ..., updates_per_step: _Optional[int] = ..., learning_starts: _Optional[int] = ..., n_step: _Optional[int] = ..., tau: _Optional[float] = ..., critic_learning_rate: _Optional[float] = ..., actor_hidden_sizes: _Optional[_Iterable[int]] = ..., critic_hidden_sizes: _Optional[_Iterable[int]] = ..., reward_scaling: _Optional[float] = ..., max_grad_norm: _Optional[float] = ..., policy_delay: _Optional[int] = ..., exploration_std_min: _Optional[float] = ..., exploration_std_max: _Optional[float] = ..., target_noise: _Optional[float] = ..., target_noise_clip: _Optional[float] = ..., initial_alpha: _Optional[float] = ..., target_entropy_scale: _Optional[float] = ..., pixels: _Optional[_Union[PixelOptions, _Mapping]] = ..., image_shift: _Optional[int] = ...) -> None: ...
