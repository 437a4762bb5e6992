from joshua_core import config_pb2 as _config_pb2
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from typing import ClassVar as _ClassVar, Optional as _Optional

DESCRIPTOR: _descriptor.FileDescriptor
RK4_COMPARE_FIELD_NUMBER: _ClassVar[int]
rk4_compare: _descriptor.FieldDescriptor

class CompareOptions(_message.Message):
    __slots__ = ("steps", "tolerance", "report_name")
    STEPS_FIELD_NUMBER: _ClassVar[int]
    TOLERANCE_FIELD_NUMBER: _ClassVar[int]
    REPORT_NAME_FIELD_NUMBER: _ClassVar[int]
    steps: int
    tolerance: float
    report_name: str
    def __init__(self, steps: _Optional[int] = ..., tolerance: _Optional[float] = ..., report_name: _Optional[str] = ...) -> None: ...
