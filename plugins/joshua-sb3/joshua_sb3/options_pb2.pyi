from joshua_core import config_pb2 as _config_pb2
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from typing import ClassVar as _ClassVar, Optional as _Optional

DESCRIPTOR: _descriptor.FileDescriptor
SB3_FIELD_NUMBER: _ClassVar[int]
sb3: _descriptor.FieldDescriptor

class Sb3Options(_message.Message):
    __slots__ = ("algorithm", "trust_checkpoint")
    ALGORITHM_FIELD_NUMBER: _ClassVar[int]
    TRUST_CHECKPOINT_FIELD_NUMBER: _ClassVar[int]
    algorithm: str
    trust_checkpoint: bool
    def __init__(self, algorithm: _Optional[str] = ..., trust_checkpoint: _Optional[bool] = ...) -> None: ...
