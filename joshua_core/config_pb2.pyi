from google.protobuf.internal import containers as _containers
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from collections.abc import Iterable as _Iterable, Mapping as _Mapping
from typing import ClassVar as _ClassVar, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor

class JoshuaConfig(_message.Message):
    __slots__ = ("operation_mode", "simulation", "training", "description", "extends")
    class OperationMode(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        SIMULATION: _ClassVar[JoshuaConfig.OperationMode]
        TRAINING: _ClassVar[JoshuaConfig.OperationMode]
    SIMULATION: JoshuaConfig.OperationMode
    TRAINING: JoshuaConfig.OperationMode
    OPERATION_MODE_FIELD_NUMBER: _ClassVar[int]
    SIMULATION_FIELD_NUMBER: _ClassVar[int]
    TRAINING_FIELD_NUMBER: _ClassVar[int]
    DESCRIPTION_FIELD_NUMBER: _ClassVar[int]
    EXTENDS_FIELD_NUMBER: _ClassVar[int]
    operation_mode: JoshuaConfig.OperationMode
    simulation: SimulationConfig
    training: TrainingConfig
    description: str
    extends: str
    def __init__(self, operation_mode: _Optional[_Union[JoshuaConfig.OperationMode, str]] = ..., simulation: _Optional[_Union[SimulationConfig, _Mapping]] = ..., training: _Optional[_Union[TrainingConfig, _Mapping]] = ..., description: _Optional[str] = ..., extends: _Optional[str] = ...) -> None: ...

class SimulationConfig(_message.Message):
    __slots__ = ("mode", "model_path", "trajectory_path", "mirror_topic_mappings", "render_width", "render_height", "backend", "keyframe", "duration", "output_dir", "offscreen", "replay", "viewer", "mirror")
    class Mode(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        INTERACTIVE: _ClassVar[SimulationConfig.Mode]
        PASSIVE: _ClassVar[SimulationConfig.Mode]
        MIRROR: _ClassVar[SimulationConfig.Mode]
        OFFSCREEN: _ClassVar[SimulationConfig.Mode]
        HEADLESS: _ClassVar[SimulationConfig.Mode]
    INTERACTIVE: SimulationConfig.Mode
    PASSIVE: SimulationConfig.Mode
    MIRROR: SimulationConfig.Mode
    OFFSCREEN: SimulationConfig.Mode
    HEADLESS: SimulationConfig.Mode
    MODE_FIELD_NUMBER: _ClassVar[int]
    MODEL_PATH_FIELD_NUMBER: _ClassVar[int]
    TRAJECTORY_PATH_FIELD_NUMBER: _ClassVar[int]
    MIRROR_TOPIC_MAPPINGS_FIELD_NUMBER: _ClassVar[int]
    RENDER_WIDTH_FIELD_NUMBER: _ClassVar[int]
    RENDER_HEIGHT_FIELD_NUMBER: _ClassVar[int]
    BACKEND_FIELD_NUMBER: _ClassVar[int]
    KEYFRAME_FIELD_NUMBER: _ClassVar[int]
    DURATION_FIELD_NUMBER: _ClassVar[int]
    OUTPUT_DIR_FIELD_NUMBER: _ClassVar[int]
    OFFSCREEN_FIELD_NUMBER: _ClassVar[int]
    REPLAY_FIELD_NUMBER: _ClassVar[int]
    VIEWER_FIELD_NUMBER: _ClassVar[int]
    MIRROR_FIELD_NUMBER: _ClassVar[int]
    mode: SimulationConfig.Mode
    model_path: str
    trajectory_path: str
    mirror_topic_mappings: MirrorTopicMappings
    render_width: int
    render_height: int
    backend: str
    keyframe: str
    duration: float
    output_dir: str
    offscreen: OffscreenOptions
    replay: ReplayOptions
    viewer: ViewerOptions
    mirror: MirrorOptions
    def __init__(self, mode: _Optional[_Union[SimulationConfig.Mode, str]] = ..., model_path: _Optional[str] = ..., trajectory_path: _Optional[str] = ..., mirror_topic_mappings: _Optional[_Union[MirrorTopicMappings, _Mapping]] = ..., render_width: _Optional[int] = ..., render_height: _Optional[int] = ..., backend: _Optional[str] = ..., keyframe: _Optional[str] = ..., duration: _Optional[float] = ..., output_dir: _Optional[str] = ..., offscreen: _Optional[_Union[OffscreenOptions, _Mapping]] = ..., replay: _Optional[_Union[ReplayOptions, _Mapping]] = ..., viewer: _Optional[_Union[ViewerOptions, _Mapping]] = ..., mirror: _Optional[_Union[MirrorOptions, _Mapping]] = ...) -> None: ...

class OffscreenOptions(_message.Message):
    __slots__ = ("camera", "fps", "output", "depth", "segmentation", "shadows")
    class Output(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        MP4: _ClassVar[OffscreenOptions.Output]
        PNG: _ClassVar[OffscreenOptions.Output]
        MP4_AND_PNG: _ClassVar[OffscreenOptions.Output]
    MP4: OffscreenOptions.Output
    PNG: OffscreenOptions.Output
    MP4_AND_PNG: OffscreenOptions.Output
    CAMERA_FIELD_NUMBER: _ClassVar[int]
    FPS_FIELD_NUMBER: _ClassVar[int]
    OUTPUT_FIELD_NUMBER: _ClassVar[int]
    DEPTH_FIELD_NUMBER: _ClassVar[int]
    SEGMENTATION_FIELD_NUMBER: _ClassVar[int]
    SHADOWS_FIELD_NUMBER: _ClassVar[int]
    camera: str
    fps: float
    output: OffscreenOptions.Output
    depth: bool
    segmentation: bool
    shadows: bool
    def __init__(self, camera: _Optional[str] = ..., fps: _Optional[float] = ..., output: _Optional[_Union[OffscreenOptions.Output, str]] = ..., depth: _Optional[bool] = ..., segmentation: _Optional[bool] = ..., shadows: _Optional[bool] = ...) -> None: ...

class ReplayOptions(_message.Message):
    __slots__ = ("speed", "loop", "as_fast_as_possible", "strict", "tracked", "velocity_limit", "penetration_threshold")
    SPEED_FIELD_NUMBER: _ClassVar[int]
    LOOP_FIELD_NUMBER: _ClassVar[int]
    AS_FAST_AS_POSSIBLE_FIELD_NUMBER: _ClassVar[int]
    STRICT_FIELD_NUMBER: _ClassVar[int]
    TRACKED_FIELD_NUMBER: _ClassVar[int]
    VELOCITY_LIMIT_FIELD_NUMBER: _ClassVar[int]
    PENETRATION_THRESHOLD_FIELD_NUMBER: _ClassVar[int]
    speed: float
    loop: bool
    as_fast_as_possible: bool
    strict: bool
    tracked: bool
    velocity_limit: float
    penetration_threshold: float
    def __init__(self, speed: _Optional[float] = ..., loop: _Optional[bool] = ..., as_fast_as_possible: _Optional[bool] = ..., strict: _Optional[bool] = ..., tracked: _Optional[bool] = ..., velocity_limit: _Optional[float] = ..., penetration_threshold: _Optional[float] = ...) -> None: ...

class ViewerOptions(_message.Message):
    __slots__ = ("display", "camera", "fps")
    class Display(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        AUTO: _ClassVar[ViewerOptions.Display]
        WINDOW: _ClassVar[ViewerOptions.Display]
        RECORD: _ClassVar[ViewerOptions.Display]
    AUTO: ViewerOptions.Display
    WINDOW: ViewerOptions.Display
    RECORD: ViewerOptions.Display
    DISPLAY_FIELD_NUMBER: _ClassVar[int]
    CAMERA_FIELD_NUMBER: _ClassVar[int]
    FPS_FIELD_NUMBER: _ClassVar[int]
    display: ViewerOptions.Display
    camera: str
    fps: float
    def __init__(self, display: _Optional[_Union[ViewerOptions.Display, str]] = ..., camera: _Optional[str] = ..., fps: _Optional[float] = ...) -> None: ...

class MirrorOptions(_message.Message):
    __slots__ = ("apply", "message_type", "joint_state_topic", "joint_state_names", "stale_timeout", "status_period", "range_margin", "display", "display_fps", "camera", "node_name")
    class Apply(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        KINEMATIC: _ClassVar[MirrorOptions.Apply]
        ACTUATOR: _ClassVar[MirrorOptions.Apply]
        KINEMATIC_AND_ACTUATOR: _ClassVar[MirrorOptions.Apply]
    KINEMATIC: MirrorOptions.Apply
    ACTUATOR: MirrorOptions.Apply
    KINEMATIC_AND_ACTUATOR: MirrorOptions.Apply
    class MessageType(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        FLOAT64: _ClassVar[MirrorOptions.MessageType]
        JOINT_STATE: _ClassVar[MirrorOptions.MessageType]
    FLOAT64: MirrorOptions.MessageType
    JOINT_STATE: MirrorOptions.MessageType
    class Display(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        AUTO: _ClassVar[MirrorOptions.Display]
        NONE: _ClassVar[MirrorOptions.Display]
        VIEWER: _ClassVar[MirrorOptions.Display]
        RECORD: _ClassVar[MirrorOptions.Display]
    AUTO: MirrorOptions.Display
    NONE: MirrorOptions.Display
    VIEWER: MirrorOptions.Display
    RECORD: MirrorOptions.Display
    class JointStateNamesEntry(_message.Message):
        __slots__ = ("key", "value")
        KEY_FIELD_NUMBER: _ClassVar[int]
        VALUE_FIELD_NUMBER: _ClassVar[int]
        key: str
        value: str
        def __init__(self, key: _Optional[str] = ..., value: _Optional[str] = ...) -> None: ...
    APPLY_FIELD_NUMBER: _ClassVar[int]
    MESSAGE_TYPE_FIELD_NUMBER: _ClassVar[int]
    JOINT_STATE_TOPIC_FIELD_NUMBER: _ClassVar[int]
    JOINT_STATE_NAMES_FIELD_NUMBER: _ClassVar[int]
    STALE_TIMEOUT_FIELD_NUMBER: _ClassVar[int]
    STATUS_PERIOD_FIELD_NUMBER: _ClassVar[int]
    RANGE_MARGIN_FIELD_NUMBER: _ClassVar[int]
    DISPLAY_FIELD_NUMBER: _ClassVar[int]
    DISPLAY_FPS_FIELD_NUMBER: _ClassVar[int]
    CAMERA_FIELD_NUMBER: _ClassVar[int]
    NODE_NAME_FIELD_NUMBER: _ClassVar[int]
    apply: MirrorOptions.Apply
    message_type: MirrorOptions.MessageType
    joint_state_topic: str
    joint_state_names: _containers.ScalarMap[str, str]
    stale_timeout: float
    status_period: float
    range_margin: float
    display: MirrorOptions.Display
    display_fps: float
    camera: str
    node_name: str
    def __init__(self, apply: _Optional[_Union[MirrorOptions.Apply, str]] = ..., message_type: _Optional[_Union[MirrorOptions.MessageType, str]] = ..., joint_state_topic: _Optional[str] = ..., joint_state_names: _Optional[_Mapping[str, str]] = ..., stale_timeout: _Optional[float] = ..., status_period: _Optional[float] = ..., range_margin: _Optional[float] = ..., display: _Optional[_Union[MirrorOptions.Display, str]] = ..., display_fps: _Optional[float] = ..., camera: _Optional[str] = ..., node_name: _Optional[str] = ...) -> None: ...

class MirrorTopicMappings(_message.Message):
    __slots__ = ("mappings",)
    MAPPINGS_FIELD_NUMBER: _ClassVar[int]
    mappings: _containers.RepeatedCompositeFieldContainer[TopicMapping]
    def __init__(self, mappings: _Optional[_Iterable[_Union[TopicMapping, _Mapping]]] = ...) -> None: ...

class TopicMapping(_message.Message):
    __slots__ = ("ros_topic", "mujoco_actuator", "offset")
    ROS_TOPIC_FIELD_NUMBER: _ClassVar[int]
    MUJOCO_ACTUATOR_FIELD_NUMBER: _ClassVar[int]
    OFFSET_FIELD_NUMBER: _ClassVar[int]
    ros_topic: str
    mujoco_actuator: str
    offset: float
    def __init__(self, ros_topic: _Optional[str] = ..., mujoco_actuator: _Optional[str] = ..., offset: _Optional[float] = ...) -> None: ...

class TrainingConfig(_message.Message):
    __slots__ = ("framework", "model_path", "num_envs", "total_timesteps", "checkpoint_dir", "num_steps", "num_epochs", "minibatch_size", "learning_rate", "gamma", "gae_lambda", "clip_epsilon", "task", "backend", "trainer", "seed", "task_config", "nthread", "sb3", "ppo")
    class Framework(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        MJX: _ClassVar[TrainingConfig.Framework]
        SB3: _ClassVar[TrainingConfig.Framework]
    MJX: TrainingConfig.Framework
    SB3: TrainingConfig.Framework
    FRAMEWORK_FIELD_NUMBER: _ClassVar[int]
    MODEL_PATH_FIELD_NUMBER: _ClassVar[int]
    NUM_ENVS_FIELD_NUMBER: _ClassVar[int]
    TOTAL_TIMESTEPS_FIELD_NUMBER: _ClassVar[int]
    CHECKPOINT_DIR_FIELD_NUMBER: _ClassVar[int]
    NUM_STEPS_FIELD_NUMBER: _ClassVar[int]
    NUM_EPOCHS_FIELD_NUMBER: _ClassVar[int]
    MINIBATCH_SIZE_FIELD_NUMBER: _ClassVar[int]
    LEARNING_RATE_FIELD_NUMBER: _ClassVar[int]
    GAMMA_FIELD_NUMBER: _ClassVar[int]
    GAE_LAMBDA_FIELD_NUMBER: _ClassVar[int]
    CLIP_EPSILON_FIELD_NUMBER: _ClassVar[int]
    TASK_FIELD_NUMBER: _ClassVar[int]
    BACKEND_FIELD_NUMBER: _ClassVar[int]
    TRAINER_FIELD_NUMBER: _ClassVar[int]
    SEED_FIELD_NUMBER: _ClassVar[int]
    TASK_CONFIG_FIELD_NUMBER: _ClassVar[int]
    NTHREAD_FIELD_NUMBER: _ClassVar[int]
    SB3_FIELD_NUMBER: _ClassVar[int]
    PPO_FIELD_NUMBER: _ClassVar[int]
    framework: TrainingConfig.Framework
    model_path: str
    num_envs: int
    total_timesteps: int
    checkpoint_dir: str
    num_steps: int
    num_epochs: int
    minibatch_size: int
    learning_rate: float
    gamma: float
    gae_lambda: float
    clip_epsilon: float
    task: str
    backend: str
    trainer: str
    seed: int
    task_config: TaskConfig
    nthread: int
    sb3: Sb3Options
    ppo: PpoOptions
    def __init__(self, framework: _Optional[_Union[TrainingConfig.Framework, str]] = ..., model_path: _Optional[str] = ..., num_envs: _Optional[int] = ..., total_timesteps: _Optional[int] = ..., checkpoint_dir: _Optional[str] = ..., num_steps: _Optional[int] = ..., num_epochs: _Optional[int] = ..., minibatch_size: _Optional[int] = ..., learning_rate: _Optional[float] = ..., gamma: _Optional[float] = ..., gae_lambda: _Optional[float] = ..., clip_epsilon: _Optional[float] = ..., task: _Optional[str] = ..., backend: _Optional[str] = ..., trainer: _Optional[str] = ..., seed: _Optional[int] = ..., task_config: _Optional[_Union[TaskConfig, _Mapping]] = ..., nthread: _Optional[int] = ..., sb3: _Optional[_Union[Sb3Options, _Mapping]] = ..., ppo: _Optional[_Union[PpoOptions, _Mapping]] = ...) -> None: ...

class PpoOptions(_message.Message):
    __slots__ = ("run_name", "resume", "checkpoint_interval", "hidden_sizes", "value_hidden_sizes", "squash_actions", "activation", "state_dependent_std", "recompute_advantages", "advantage", "entropy_coef", "reward_scaling", "unrolls_per_iteration", "max_grad_norm", "desired_kl", "anneal_learning_rate", "disable_observation_normalization", "value_coef", "video_interval", "video_steps", "viewer", "viewer_envs")
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
    RUN_NAME_FIELD_NUMBER: _ClassVar[int]
    RESUME_FIELD_NUMBER: _ClassVar[int]
    CHECKPOINT_INTERVAL_FIELD_NUMBER: _ClassVar[int]
    HIDDEN_SIZES_FIELD_NUMBER: _ClassVar[int]
    VALUE_HIDDEN_SIZES_FIELD_NUMBER: _ClassVar[int]
    SQUASH_ACTIONS_FIELD_NUMBER: _ClassVar[int]
    ACTIVATION_FIELD_NUMBER: _ClassVar[int]
    STATE_DEPENDENT_STD_FIELD_NUMBER: _ClassVar[int]
    RECOMPUTE_ADVANTAGES_FIELD_NUMBER: _ClassVar[int]
    ADVANTAGE_FIELD_NUMBER: _ClassVar[int]
    ENTROPY_COEF_FIELD_NUMBER: _ClassVar[int]
    REWARD_SCALING_FIELD_NUMBER: _ClassVar[int]
    UNROLLS_PER_ITERATION_FIELD_NUMBER: _ClassVar[int]
    MAX_GRAD_NORM_FIELD_NUMBER: _ClassVar[int]
    DESIRED_KL_FIELD_NUMBER: _ClassVar[int]
    ANNEAL_LEARNING_RATE_FIELD_NUMBER: _ClassVar[int]
    DISABLE_OBSERVATION_NORMALIZATION_FIELD_NUMBER: _ClassVar[int]
    VALUE_COEF_FIELD_NUMBER: _ClassVar[int]
    VIDEO_INTERVAL_FIELD_NUMBER: _ClassVar[int]
    VIDEO_STEPS_FIELD_NUMBER: _ClassVar[int]
    VIEWER_FIELD_NUMBER: _ClassVar[int]
    VIEWER_ENVS_FIELD_NUMBER: _ClassVar[int]
    run_name: str
    resume: bool
    checkpoint_interval: int
    hidden_sizes: _containers.RepeatedScalarFieldContainer[int]
    value_hidden_sizes: _containers.RepeatedScalarFieldContainer[int]
    squash_actions: bool
    activation: str
    state_dependent_std: bool
    recompute_advantages: bool
    advantage: PpoOptions.Advantage
    entropy_coef: float
    reward_scaling: float
    unrolls_per_iteration: int
    max_grad_norm: float
    desired_kl: float
    anneal_learning_rate: bool
    disable_observation_normalization: bool
    value_coef: float
    video_interval: int
    video_steps: int
    viewer: PpoOptions.Viewer
    viewer_envs: int
    def __init__(self, run_name: _Optional[str] = ..., resume: _Optional[bool] = ..., checkpoint_interval: _Optional[int] = ..., hidden_sizes: _Optional[_Iterable[int]] = ..., value_hidden_sizes: _Optional[_Iterable[int]] = ..., squash_actions: _Optional[bool] = ..., activation: _Optional[str] = ..., state_dependent_std: _Optional[bool] = ..., recompute_advantages: _Optional[bool] = ..., advantage: _Optional[_Union[PpoOptions.Advantage, str]] = ..., entropy_coef: _Optional[float] = ..., reward_scaling: _Optional[float] = ..., unrolls_per_iteration: _Optional[int] = ..., max_grad_norm: _Optional[float] = ..., desired_kl: _Optional[float] = ..., anneal_learning_rate: _Optional[bool] = ..., disable_observation_normalization: _Optional[bool] = ..., value_coef: _Optional[float] = ..., video_interval: _Optional[int] = ..., video_steps: _Optional[int] = ..., viewer: _Optional[_Union[PpoOptions.Viewer, str]] = ..., viewer_envs: _Optional[int] = ...) -> None: ...

class Sb3Options(_message.Message):
    __slots__ = ("algorithm", "run_name", "resume", "checkpoint_interval", "hidden_sizes", "disable_normalization", "entropy_coef", "trust_checkpoint")
    ALGORITHM_FIELD_NUMBER: _ClassVar[int]
    RUN_NAME_FIELD_NUMBER: _ClassVar[int]
    RESUME_FIELD_NUMBER: _ClassVar[int]
    CHECKPOINT_INTERVAL_FIELD_NUMBER: _ClassVar[int]
    HIDDEN_SIZES_FIELD_NUMBER: _ClassVar[int]
    DISABLE_NORMALIZATION_FIELD_NUMBER: _ClassVar[int]
    ENTROPY_COEF_FIELD_NUMBER: _ClassVar[int]
    TRUST_CHECKPOINT_FIELD_NUMBER: _ClassVar[int]
    algorithm: str
    run_name: str
    resume: bool
    checkpoint_interval: int
    hidden_sizes: _containers.RepeatedScalarFieldContainer[int]
    disable_normalization: bool
    entropy_coef: float
    trust_checkpoint: bool
    def __init__(self, algorithm: _Optional[str] = ..., run_name: _Optional[str] = ..., resume: _Optional[bool] = ..., checkpoint_interval: _Optional[int] = ..., hidden_sizes: _Optional[_Iterable[int]] = ..., disable_normalization: _Optional[bool] = ..., entropy_coef: _Optional[float] = ..., trust_checkpoint: _Optional[bool] = ...) -> None: ...

class TaskConfig(_message.Message):
    __slots__ = ("episode_length", "frame_skip", "terms", "keyframe")
    EPISODE_LENGTH_FIELD_NUMBER: _ClassVar[int]
    FRAME_SKIP_FIELD_NUMBER: _ClassVar[int]
    TERMS_FIELD_NUMBER: _ClassVar[int]
    KEYFRAME_FIELD_NUMBER: _ClassVar[int]
    episode_length: int
    frame_skip: int
    terms: _containers.RepeatedCompositeFieldContainer[TermOverride]
    keyframe: str
    def __init__(self, episode_length: _Optional[int] = ..., frame_skip: _Optional[int] = ..., terms: _Optional[_Iterable[_Union[TermOverride, _Mapping]]] = ..., keyframe: _Optional[str] = ...) -> None: ...

class TermOverride(_message.Message):
    __slots__ = ("name", "weight", "params", "term", "kind")
    class Kind(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        KIND_UNSPECIFIED: _ClassVar[TermOverride.Kind]
        OBSERVATION: _ClassVar[TermOverride.Kind]
        REWARD: _ClassVar[TermOverride.Kind]
        TERMINATION: _ClassVar[TermOverride.Kind]
        RESET: _ClassVar[TermOverride.Kind]
        METRIC: _ClassVar[TermOverride.Kind]
    KIND_UNSPECIFIED: TermOverride.Kind
    OBSERVATION: TermOverride.Kind
    REWARD: TermOverride.Kind
    TERMINATION: TermOverride.Kind
    RESET: TermOverride.Kind
    METRIC: TermOverride.Kind
    class ParamsEntry(_message.Message):
        __slots__ = ("key", "value")
        KEY_FIELD_NUMBER: _ClassVar[int]
        VALUE_FIELD_NUMBER: _ClassVar[int]
        key: str
        value: str
        def __init__(self, key: _Optional[str] = ..., value: _Optional[str] = ...) -> None: ...
    NAME_FIELD_NUMBER: _ClassVar[int]
    WEIGHT_FIELD_NUMBER: _ClassVar[int]
    PARAMS_FIELD_NUMBER: _ClassVar[int]
    TERM_FIELD_NUMBER: _ClassVar[int]
    KIND_FIELD_NUMBER: _ClassVar[int]
    name: str
    weight: float
    params: _containers.ScalarMap[str, str]
    term: str
    kind: TermOverride.Kind
    def __init__(self, name: _Optional[str] = ..., weight: _Optional[float] = ..., params: _Optional[_Mapping[str, str]] = ..., term: _Optional[str] = ..., kind: _Optional[_Union[TermOverride.Kind, str]] = ...) -> None: ...
