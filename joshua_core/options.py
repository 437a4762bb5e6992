"""Plugin-owned options: protobuf extensions of the config messages, known by their short names.

A plugin declares its options in a .proto of its own as an extension of `joshua.SimulationConfig` or
`joshua.TrainingConfig` (`extend joshua.SimulationConfig { OffscreenOptions offscreen = 1000; }`),
commits the generated `_pb2` module and registers the extension with the hook
`joshua_register_options`. Configs, `--set`, `--print-config` and the dicts of `config.json` files
name it by its short name (`offscreen`) as if it were a field; an `OptionSet` is what the loader
knows of them. Plugin code reads its options with `options_of(config, extension)`.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from google.protobuf import json_format
from google.protobuf.descriptor import Descriptor, FieldDescriptor
from google.protobuf.message import Message

from joshua_core import legacy


@dataclass(frozen=True)
class OptionSet:
    """The option extensions a config may use, found by the message they extend and their short name.

    `lenient` sets skip every name they do not know instead of rejecting it: they read what the core
    schema holds (a preset's description, the mode and trainer it needs) before any plugin's options
    are loaded.
    """

    extensions: tuple[FieldDescriptor, ...] = ()
    lenient: bool = False
    # Per option (its full name): its old fields that moved to the message it extends, {old name: new name}, which
    # the loaders read as the new ones (`joshua_core.legacy`).
    moved: Mapping[str, Mapping[str, str]] = field(default_factory=dict)

    def find(self, message: Descriptor, name: str) -> FieldDescriptor | None:
        """The registered extension of `message` named `name` (short or full name), if any."""
        for extension in self.extensions:
            if extension.containing_type.full_name == message.full_name and name in (
                extension.name,
                extension.full_name,
            ):
                return extension
        return None

    def moved_field(self, option: FieldDescriptor | None, name: str) -> str | None:
        """The field of the extended message that the old field `name` of the option `option` moved to, if any."""
        if option is None or not option.is_extension:
            return None
        return self.moved.get(option.full_name, {}).get(name)

    def names(self, message: Descriptor) -> list[str]:
        """Sorted short names of the registered extensions of `message`."""
        return sorted(e.name for e in self.extensions if e.containing_type.full_name == message.full_name)


LENIENT = OptionSet(lenient=True)


def field_or_option(message: Descriptor, name: str, options: OptionSet) -> FieldDescriptor | None:
    """The field `name` of `message`, else its registered option of that short name, else None."""
    return message.fields_by_name.get(name) or options.find(message, name)


def close_names(message: Descriptor, name: str, options: OptionSet) -> str:
    """' Did you mean: a, b?' naming the fields and options of `message` close to `name`, or ''."""
    candidates = [*message.fields_by_name, *options.names(message)]
    close = difflib.get_close_matches(name, candidates, n=3)
    return f" Did you mean: {', '.join(close)}?" if close else ""


def sub_message(message: Message, field: FieldDescriptor) -> Any:
    """The value of a field or extension of `message` (for a message field: the live sub-message)."""
    return message.Extensions[field] if field.is_extension else getattr(message, field.name)


def options_of(message: Message, extension: FieldDescriptor) -> Any:
    """A plugin's options in a config message: `options_of(config, offscreen)` is the OffscreenOptions that
    `simulation { offscreen { ... } }` set, empty (every field at its default) when the config sets none."""
    return message.Extensions[extension]


def message_to_dict(message: Message) -> dict[str, Any]:
    """`json_format.MessageToDict` (proto field names) with options under their short names, as configs write them."""
    return _shorten(json_format.MessageToDict(message, preserving_proto_field_name=True))


def _shorten(value: Any) -> Any:
    if isinstance(value, dict):
        return {_short_key(key): _shorten(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_shorten(item) for item in value]
    return value


def _short_key(key: str) -> str:
    """'[joshua_ppo.ppo]' -> 'ppo'; other keys unchanged."""
    return key[1:-1].rpartition(".")[2] if key.startswith("[") and key.endswith("]") else key


def parse_dict(data: Mapping[str, Any], message: Message, options: OptionSet, source: str = "config") -> None:
    """`json_format.ParseDict` into `message`, reading options by their short names (or bracketed full names);
    `source` (e.g. a config.json's path) is where the notice of an old spelling says it is."""
    json_format.ParseDict(_bracketed(data, message.DESCRIPTOR, options, source), message)


def _bracketed(data: Any, descriptor: Descriptor | None, options: OptionSet, source: str) -> Any:
    """A copy of `data` with each option's short name replaced by `[full.name]`, which ParseDict reads, each
    old field (`joshua_core.legacy`) by the fields it stood for that `data` does not set itself, and each option's
    field that moved to `data`'s message (`OptionSet.moved`) moved there."""
    if descriptor is None or not isinstance(data, Mapping):
        return data
    result: dict[Any, Any] = {}
    for key, value in data.items():
        if isinstance(key, str) and legacy.is_renamed(descriptor.full_name, key):
            fields = legacy.framework_fields(value)
            if fields is None:
                raise json_format.ParseError(legacy.unknown_framework(value))
            result.update({name: item for name, item in fields.items() if name not in data})
            continue
        field = field_or_option(descriptor, key, options) if isinstance(key, str) else None
        if field is not None and field.is_extension:
            key = f"[{field.full_name}]"
            if isinstance(value, Mapping) and value:
                value = _moved_out(value, field, data, result, options, source)
                if not value:  # the option held only moved fields: it is unset
                    continue
        child = field.message_type if field is not None else None
        if child is not None and child.GetOptions().map_entry:
            value_type = child.fields_by_name["value"].message_type
            if isinstance(value, Mapping):
                value = {k: _bracketed(v, value_type, options, source) for k, v in value.items()}
        elif isinstance(value, list):
            value = [_bracketed(item, child, options, source) for item in value]
        else:
            value = _bracketed(value, child, options, source)
        result[key] = value
    return result


def _moved_out(
    values: Mapping[str, Any],
    option: FieldDescriptor,
    parent: Mapping[str, Any],
    result: dict[Any, Any],
    options: OptionSet,
    source: str,
) -> dict[str, Any]:
    """The option's `values` without its old fields that moved to the message it extends (`OptionSet.moved`), each
    put into `result` (the parent's copy) under its new name, with a notice; one that `parent` (or another option)
    sets differently is a ParseError."""
    kept = {}
    for key, value in values.items():
        new = options.moved_field(option, key)
        if new is None:
            kept[key] = value
            continue
        legacy.moved_notice(source, option, key, new)
        if parent.get(new, value) != value or result.get(new, value) != value:
            raise json_format.ParseError(legacy.moved_conflict(option, key, new))
        result[new] = value
    return kept
