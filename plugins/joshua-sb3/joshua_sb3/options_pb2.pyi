from joshua_core import config_pb2 as _config_pb2
from google.protobuf.internal import containers as _containers
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from collections.abc import Iterable as _Iterable
from typing import ClassVar as _ClassVar, Optional as _Optional

DESCRIPTOR: _descriptor.FileDescriptor
SB3_FIELD_NUMBER: _ClassVar[int]
sb3: _descriptor.FieldDescriptor

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
