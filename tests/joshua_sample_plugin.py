"""A third-party plugin for the tests: the mode SAMPLE and its options `sample`, added without touching the core.

Its options are a protobuf extension of joshua.SimulationConfig (field 10001, the third-party range),
declared here at import time as a generated `_pb2` module would (a plugin normally compiles a .proto;
see docs/examples/joshua-rk4). The mode writes the options it was given to `sample.json`, so a test
sees what a config, `--set` and `extends` made of them. Used in-process and as an installed entry point.
"""

from __future__ import annotations

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

from joshua_core import hookimpl
from joshua_core.atomic import atomic_write_json
from joshua_core.config_pb2 import SimulationConfig  # loads joshua/config.proto, which this file extends
from joshua_core.interfaces import Mode
from joshua_core.options import message_to_dict, options_of
from joshua_core.plugins import Registrar
from joshua_core.run_context import RunContext

FILE_NAME = "joshua_sample/options.proto"
_FIELD = descriptor_pb2.FieldDescriptorProto


def _declare() -> descriptor_pb2.FileDescriptorProto:
    file = descriptor_pb2.FileDescriptorProto(
        name=FILE_NAME, package="joshua_sample", dependency=["joshua/config.proto"], syntax="proto3"
    )
    options = file.message_type.add(name="SampleOptions")
    options.field.add(name="level", number=1, type=_FIELD.TYPE_INT32, label=_FIELD.LABEL_OPTIONAL)
    options.field.add(name="sizes", number=2, type=_FIELD.TYPE_INT32, label=_FIELD.LABEL_REPEATED)
    options.field.add(name="label", number=3, type=_FIELD.TYPE_STRING, label=_FIELD.LABEL_OPTIONAL)
    file.extension.add(
        name="sample",
        number=10001,
        type=_FIELD.TYPE_MESSAGE,
        label=_FIELD.LABEL_OPTIONAL,
        type_name=".joshua_sample.SampleOptions",
        extendee=".joshua.SimulationConfig",
    )
    return file


def _file() -> object:
    pool = descriptor_pool.Default()
    try:
        return pool.FindFileByName(FILE_NAME)  # already declared in this process
    except KeyError:
        return pool.AddSerializedFile(_declare().SerializeToString())


_DESCRIPTOR = _file()
sample = _DESCRIPTOR.extensions_by_name["sample"]
SampleOptions = message_factory.GetMessageClass(_DESCRIPTOR.message_types_by_name["SampleOptions"])


class SampleMode(Mode):
    """Writes the `sample` options it was given (short names, as configs write them) to sample.json."""

    def run(self, config: SimulationConfig, context: RunContext) -> None:
        context.output_dir.mkdir(parents=True, exist_ok=True)
        atomic_write_json(context.output_dir / "sample.json", message_to_dict(options_of(config, sample)))


@hookimpl
def joshua_register_modes(registry: Registrar) -> None:
    registry.add("SAMPLE", SampleMode, "writes its options to sample.json")


@hookimpl
def joshua_register_options(registry: Registrar) -> None:
    registry.add("sample", "joshua_sample_plugin:sample", "SAMPLE: level, sizes, label")
