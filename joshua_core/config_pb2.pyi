from google.protobuf.internal import containers as _containers
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf.internal import python_message as _python_message
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
    __slots__ = ("mode", "model_path", "trajectory_path", "render_width", "render_height", "backend", "keyframe", "duration", "output_dir", "web")
    Extensions: _python_message._ExtensionDict
    MODE_FIELD_NUMBER: _ClassVar[int]
    MODEL_PATH_FIELD_NUMBER: _ClassVar[int]
    TRAJECTORY_PATH_FIELD_NUMBER: _ClassVar[int]
    RENDER_WIDTH_FIELD_NUMBER: _ClassVar[int]
    RENDER_HEIGHT_FIELD_NUMBER: _ClassVar[int]
    BACKEND_FIELD_NUMBER: _ClassVar[int]
    KEYFRAME_FIELD_NUMBER: _ClassVar[int]
    DURATION_FIELD_NUMBER: _ClassVar[int]
    OUTPUT_DIR_FIELD_NUMBER: _ClassVar[int]
    WEB_FIELD_NUMBER: _ClassVar[int]
    mode: str
    model_path: str
    trajectory_path: str
    render_width: int
    render_height: int
    backend: str
    keyframe: str
    duration: float
    output_dir: str
    web: str
    def __init__(self, mode: _Optional[str] = ..., model_path: _Optional[str] = ..., trajectory_path: _Optional[str] = ..., render_width: _Optional[int] = ..., render_height: _Optional[int] = ..., backend: _Optional[str] = ..., keyframe: _Optional[str] = ..., duration: _Optional[float] = ..., output_dir: _Optional[str] = ..., web: _Optional[str] = ...) -> None: ...

class TrainingConfig(_message.Message):
    __slots__ = ("model_path", "num_envs", "total_timesteps", "checkpoint_dir", "num_steps", "num_epochs", "minibatch_size", "learning_rate", "gamma", "gae_lambda", "clip_epsilon", "task", "backend", "trainer", "seed", "task_config", "synchronized_episodes", "nthread", "web", "deterministic", "run_name", "resume", "checkpoint_interval", "hidden_sizes", "disable_normalization", "entropy_coef")
    Extensions: _python_message._ExtensionDict
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
    SYNCHRONIZED_EPISODES_FIELD_NUMBER: _ClassVar[int]
    NTHREAD_FIELD_NUMBER: _ClassVar[int]
    WEB_FIELD_NUMBER: _ClassVar[int]
    DETERMINISTIC_FIELD_NUMBER: _ClassVar[int]
    RUN_NAME_FIELD_NUMBER: _ClassVar[int]
    RESUME_FIELD_NUMBER: _ClassVar[int]
    CHECKPOINT_INTERVAL_FIELD_NUMBER: _ClassVar[int]
    HIDDEN_SIZES_FIELD_NUMBER: _ClassVar[int]
    DISABLE_NORMALIZATION_FIELD_NUMBER: _ClassVar[int]
    ENTROPY_COEF_FIELD_NUMBER: _ClassVar[int]
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
    synchronized_episodes: bool
    nthread: int
    web: str
    deterministic: bool
    run_name: str
    resume: bool
    checkpoint_interval: int
    hidden_sizes: _containers.RepeatedScalarFieldContainer[int]
    disable_normalization: bool
    entropy_coef: float
    def __init__(self, model_path: _Optional[str] = ..., num_envs: _Optional[int] = ..., total_timesteps: _Optional[int] = ..., checkpoint_dir: _Optional[str] = ..., num_steps: _Optional[int] = ..., num_epochs: _Optional[int] = ..., minibatch_size: _Optional[int] = ..., learning_rate: _Optional[float] = ..., gamma: _Optional[float] = ..., gae_lambda: _Optional[float] = ..., clip_epsilon: _Optional[float] = ..., task: _Optional[str] = ..., backend: _Optional[str] = ..., trainer: _Optional[str] = ..., seed: _Optional[int] = ..., task_config: _Optional[_Union[TaskConfig, _Mapping]] = ..., synchronized_episodes: _Optional[bool] = ..., nthread: _Optional[int] = ..., web: _Optional[str] = ..., deterministic: _Optional[bool] = ..., run_name: _Optional[str] = ..., resume: _Optional[bool] = ..., checkpoint_interval: _Optional[int] = ..., hidden_sizes: _Optional[_Iterable[int]] = ..., disable_normalization: _Optional[bool] = ..., entropy_coef: _Optional[float] = ...) -> None: ...

class TaskConfig(_message.Message):
    __slots__ = ("episode_length", "frame_skip", "terms", "keyframe", "events", "action", "randomization_curriculum", "cameras")
    EPISODE_LENGTH_FIELD_NUMBER: _ClassVar[int]
    FRAME_SKIP_FIELD_NUMBER: _ClassVar[int]
    TERMS_FIELD_NUMBER: _ClassVar[int]
    KEYFRAME_FIELD_NUMBER: _ClassVar[int]
    EVENTS_FIELD_NUMBER: _ClassVar[int]
    ACTION_FIELD_NUMBER: _ClassVar[int]
    RANDOMIZATION_CURRICULUM_FIELD_NUMBER: _ClassVar[int]
    CAMERAS_FIELD_NUMBER: _ClassVar[int]
    episode_length: int
    frame_skip: int
    terms: _containers.RepeatedCompositeFieldContainer[TermOverride]
    keyframe: str
    events: _containers.RepeatedCompositeFieldContainer[EventConfig]
    action: ActionConfig
    randomization_curriculum: RandomizationCurriculum
    cameras: _containers.RepeatedCompositeFieldContainer[CameraConfig]
    def __init__(self, episode_length: _Optional[int] = ..., frame_skip: _Optional[int] = ..., terms: _Optional[_Iterable[_Union[TermOverride, _Mapping]]] = ..., keyframe: _Optional[str] = ..., events: _Optional[_Iterable[_Union[EventConfig, _Mapping]]] = ..., action: _Optional[_Union[ActionConfig, _Mapping]] = ..., randomization_curriculum: _Optional[_Union[RandomizationCurriculum, _Mapping]] = ..., cameras: _Optional[_Iterable[_Union[CameraConfig, _Mapping]]] = ...) -> None: ...

class CameraConfig(_message.Message):
    __slots__ = ("camera", "width", "height", "kind", "every_steps")
    class Kind(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        KIND_UNSPECIFIED: _ClassVar[CameraConfig.Kind]
        RGB: _ClassVar[CameraConfig.Kind]
        DEPTH: _ClassVar[CameraConfig.Kind]
        SEGMENTATION: _ClassVar[CameraConfig.Kind]
    KIND_UNSPECIFIED: CameraConfig.Kind
    RGB: CameraConfig.Kind
    DEPTH: CameraConfig.Kind
    SEGMENTATION: CameraConfig.Kind
    CAMERA_FIELD_NUMBER: _ClassVar[int]
    WIDTH_FIELD_NUMBER: _ClassVar[int]
    HEIGHT_FIELD_NUMBER: _ClassVar[int]
    KIND_FIELD_NUMBER: _ClassVar[int]
    EVERY_STEPS_FIELD_NUMBER: _ClassVar[int]
    camera: str
    width: int
    height: int
    kind: CameraConfig.Kind
    every_steps: int
    def __init__(self, camera: _Optional[str] = ..., width: _Optional[int] = ..., height: _Optional[int] = ..., kind: _Optional[_Union[CameraConfig.Kind, str]] = ..., every_steps: _Optional[int] = ...) -> None: ...

class RandomizationCurriculum(_message.Message):
    __slots__ = ("metric", "start", "step_up", "step_down")
    METRIC_FIELD_NUMBER: _ClassVar[int]
    START_FIELD_NUMBER: _ClassVar[int]
    STEP_UP_FIELD_NUMBER: _ClassVar[int]
    STEP_DOWN_FIELD_NUMBER: _ClassVar[int]
    metric: str
    start: float
    step_up: float
    step_down: float
    def __init__(self, metric: _Optional[str] = ..., start: _Optional[float] = ..., step_up: _Optional[float] = ..., step_down: _Optional[float] = ...) -> None: ...

class ActionConfig(_message.Message):
    __slots__ = ("mode", "scale")
    MODE_FIELD_NUMBER: _ClassVar[int]
    SCALE_FIELD_NUMBER: _ClassVar[int]
    mode: str
    scale: float
    def __init__(self, mode: _Optional[str] = ..., scale: _Optional[float] = ...) -> None: ...

class EventConfig(_message.Message):
    __slots__ = ("name", "term", "params", "mode", "interval_steps")
    class Mode(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        MODE_UNSPECIFIED: _ClassVar[EventConfig.Mode]
        RESET: _ClassVar[EventConfig.Mode]
        INTERVAL: _ClassVar[EventConfig.Mode]
    MODE_UNSPECIFIED: EventConfig.Mode
    RESET: EventConfig.Mode
    INTERVAL: EventConfig.Mode
    class ParamsEntry(_message.Message):
        __slots__ = ("key", "value")
        KEY_FIELD_NUMBER: _ClassVar[int]
        VALUE_FIELD_NUMBER: _ClassVar[int]
        key: str
        value: str
        def __init__(self, key: _Optional[str] = ..., value: _Optional[str] = ...) -> None: ...
    NAME_FIELD_NUMBER: _ClassVar[int]
    TERM_FIELD_NUMBER: _ClassVar[int]
    PARAMS_FIELD_NUMBER: _ClassVar[int]
    MODE_FIELD_NUMBER: _ClassVar[int]
    INTERVAL_STEPS_FIELD_NUMBER: _ClassVar[int]
    name: str
    term: str
    params: _containers.ScalarMap[str, str]
    mode: EventConfig.Mode
    interval_steps: int
    def __init__(self, name: _Optional[str] = ..., term: _Optional[str] = ..., params: _Optional[_Mapping[str, str]] = ..., mode: _Optional[_Union[EventConfig.Mode, str]] = ..., interval_steps: _Optional[int] = ...) -> None: ...

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
