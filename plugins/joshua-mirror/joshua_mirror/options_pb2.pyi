from joshua_core import config_pb2 as _config_pb2
from google.protobuf.internal import containers as _containers
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from collections.abc import Iterable as _Iterable, Mapping as _Mapping
from typing import ClassVar as _ClassVar, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor
MIRROR_FIELD_NUMBER: _ClassVar[int]
mirror: _descriptor.FieldDescriptor
MIRROR_TOPIC_MAPPINGS_FIELD_NUMBER: _ClassVar[int]
mirror_topic_mappings: _descriptor.FieldDescriptor

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

class MirrorOptions(_message.Message):
    __slots__ = ("apply", "message_type", "joint_state_topic", "joint_state_names", "stale_timeout", "status_period", "range_margin", "display", "display_fps", "camera", "node_name", "command_topics", "record", "lerobot")
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
        WEB: _ClassVar[MirrorOptions.Display]
    AUTO: MirrorOptions.Display
    NONE: MirrorOptions.Display
    VIEWER: MirrorOptions.Display
    RECORD: MirrorOptions.Display
    WEB: MirrorOptions.Display
    class JointStateNamesEntry(_message.Message):
        __slots__ = ("key", "value")
        KEY_FIELD_NUMBER: _ClassVar[int]
        VALUE_FIELD_NUMBER: _ClassVar[int]
        key: str
        value: str
        def __init__(self, key: _Optional[str] = ..., value: _Optional[str] = ...) -> None: ...
    class CommandTopicsEntry(_message.Message):
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
    COMMAND_TOPICS_FIELD_NUMBER: _ClassVar[int]
    RECORD_FIELD_NUMBER: _ClassVar[int]
    LEROBOT_FIELD_NUMBER: _ClassVar[int]
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
    command_topics: _containers.ScalarMap[str, str]
    record: MirrorRecording
    lerobot: MirrorLeRobot
    def __init__(self, apply: _Optional[_Union[MirrorOptions.Apply, str]] = ..., message_type: _Optional[_Union[MirrorOptions.MessageType, str]] = ..., joint_state_topic: _Optional[str] = ..., joint_state_names: _Optional[_Mapping[str, str]] = ..., stale_timeout: _Optional[float] = ..., status_period: _Optional[float] = ..., range_margin: _Optional[float] = ..., display: _Optional[_Union[MirrorOptions.Display, str]] = ..., display_fps: _Optional[float] = ..., camera: _Optional[str] = ..., node_name: _Optional[str] = ..., command_topics: _Optional[_Mapping[str, str]] = ..., record: _Optional[_Union[MirrorRecording, _Mapping]] = ..., lerobot: _Optional[_Union[MirrorLeRobot, _Mapping]] = ...) -> None: ...

class MirrorLeRobot(_message.Message):
    __slots__ = ("robot_type", "port", "calibration", "units", "rate")
    class Units(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        DEGREES: _ClassVar[MirrorLeRobot.Units]
        RANGE: _ClassVar[MirrorLeRobot.Units]
    DEGREES: MirrorLeRobot.Units
    RANGE: MirrorLeRobot.Units
    ROBOT_TYPE_FIELD_NUMBER: _ClassVar[int]
    PORT_FIELD_NUMBER: _ClassVar[int]
    CALIBRATION_FIELD_NUMBER: _ClassVar[int]
    UNITS_FIELD_NUMBER: _ClassVar[int]
    RATE_FIELD_NUMBER: _ClassVar[int]
    robot_type: str
    port: str
    calibration: str
    units: MirrorLeRobot.Units
    rate: float
    def __init__(self, robot_type: _Optional[str] = ..., port: _Optional[str] = ..., calibration: _Optional[str] = ..., units: _Optional[_Union[MirrorLeRobot.Units, str]] = ..., rate: _Optional[float] = ...) -> None: ...

class MirrorRecording(_message.Message):
    __slots__ = ("csv", "lerobot", "fps", "task", "cameras")
    CSV_FIELD_NUMBER: _ClassVar[int]
    LEROBOT_FIELD_NUMBER: _ClassVar[int]
    FPS_FIELD_NUMBER: _ClassVar[int]
    TASK_FIELD_NUMBER: _ClassVar[int]
    CAMERAS_FIELD_NUMBER: _ClassVar[int]
    csv: bool
    lerobot: bool
    fps: int
    task: str
    cameras: _containers.RepeatedScalarFieldContainer[str]
    def __init__(self, csv: _Optional[bool] = ..., lerobot: _Optional[bool] = ..., fps: _Optional[int] = ..., task: _Optional[str] = ..., cameras: _Optional[_Iterable[str]] = ...) -> None: ...
