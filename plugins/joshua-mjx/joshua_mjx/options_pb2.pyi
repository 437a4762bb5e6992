from joshua_core import config_pb2 as _config_pb2
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from typing import ClassVar as _ClassVar, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor
MJX_FIELD_NUMBER: _ClassVar[int]
mjx: _descriptor.FieldDescriptor

class MjxOptions(_message.Message):
    __slots__ = ("impl", "nconmax", "njmax")
    class Impl(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        JAX: _ClassVar[MjxOptions.Impl]
        WARP: _ClassVar[MjxOptions.Impl]
    JAX: MjxOptions.Impl
    WARP: MjxOptions.Impl
    IMPL_FIELD_NUMBER: _ClassVar[int]
    NCONMAX_FIELD_NUMBER: _ClassVar[int]
    NJMAX_FIELD_NUMBER: _ClassVar[int]
    impl: MjxOptions.Impl
    nconmax: int
    njmax: int
    def __init__(self, impl: _Optional[_Union[MjxOptions.Impl, str]] = ..., nconmax: _Optional[int] = ..., njmax: _Optional[int] = ...) -> None: ...
