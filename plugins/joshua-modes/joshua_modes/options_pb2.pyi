from joshua_core import config_pb2 as _config_pb2
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from typing import ClassVar as _ClassVar, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor
OFFSCREEN_FIELD_NUMBER: _ClassVar[int]
offscreen: _descriptor.FieldDescriptor
REPLAY_FIELD_NUMBER: _ClassVar[int]
replay: _descriptor.FieldDescriptor
VIEWER_FIELD_NUMBER: _ClassVar[int]
viewer: _descriptor.FieldDescriptor

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
    __slots__ = ("speed", "loop", "as_fast_as_possible", "strict", "tracked", "velocity_limit", "penetration_threshold", "episode")
    SPEED_FIELD_NUMBER: _ClassVar[int]
    LOOP_FIELD_NUMBER: _ClassVar[int]
    AS_FAST_AS_POSSIBLE_FIELD_NUMBER: _ClassVar[int]
    STRICT_FIELD_NUMBER: _ClassVar[int]
    TRACKED_FIELD_NUMBER: _ClassVar[int]
    VELOCITY_LIMIT_FIELD_NUMBER: _ClassVar[int]
    PENETRATION_THRESHOLD_FIELD_NUMBER: _ClassVar[int]
    EPISODE_FIELD_NUMBER: _ClassVar[int]
    speed: float
    loop: bool
    as_fast_as_possible: bool
    strict: bool
    tracked: bool
    velocity_limit: float
    penetration_threshold: float
    episode: int
    def __init__(self, speed: _Optional[float] = ..., loop: _Optional[bool] = ..., as_fast_as_possible: _Optional[bool] = ..., strict: _Optional[bool] = ..., tracked: _Optional[bool] = ..., velocity_limit: _Optional[float] = ..., penetration_threshold: _Optional[float] = ..., episode: _Optional[int] = ...) -> None: ...

class ViewerOptions(_message.Message):
    __slots__ = ("display", "camera", "fps")
    class Display(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        AUTO: _ClassVar[ViewerOptions.Display]
        WINDOW: _ClassVar[ViewerOptions.Display]
        RECORD: _ClassVar[ViewerOptions.Display]
        WEB: _ClassVar[ViewerOptions.Display]
    AUTO: ViewerOptions.Display
    WINDOW: ViewerOptions.Display
    RECORD: ViewerOptions.Display
    WEB: ViewerOptions.Display
    DISPLAY_FIELD_NUMBER: _ClassVar[int]
    CAMERA_FIELD_NUMBER: _ClassVar[int]
    FPS_FIELD_NUMBER: _ClassVar[int]
    display: ViewerOptions.Display
    camera: str
    fps: float
    def __init__(self, display: _Optional[_Union[ViewerOptions.Display, str]] = ..., camera: _Optional[str] = ..., fps: _Optional[float] = ...) -> None: ...
