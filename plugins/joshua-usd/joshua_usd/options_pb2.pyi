from joshua_core import config_pb2 as _config_pb2
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from typing import ClassVar as _ClassVar, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor
USD_FIELD_NUMBER: _ClassVar[int]
usd: _descriptor.FieldDescriptor

class UsdOptions(_message.Message):
    __slots__ = ("physics",)
    class Physics(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
        __slots__ = ()
        MUJOCO: _ClassVar[UsdOptions.Physics]
        PHYSX: _ClassVar[UsdOptions.Physics]
    MUJOCO: UsdOptions.Physics
    PHYSX: UsdOptions.Physics
    PHYSICS_FIELD_NUMBER: _ClassVar[int]
    physics: UsdOptions.Physics
    def __init__(self, physics: _Optional[_Union[UsdOptions.Physics, str]] = ...) -> None: ...
