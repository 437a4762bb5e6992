"""Loading configs: presets and `.pbtxt` files (text-format JoshuaConfig), `extends`, `--set` overrides.

Plugins' options are extensions of the config messages, named by their short names
(`joshua_core.options`); every loader takes the `OptionSet` it may use: the run's
(`PluginHost.options()`), or `LENIENT` to read only what the core schema holds. Errors always point at
the input: `file:line:col` for parse errors, the close names for an unknown preset, the field and option
names available for a bad `--set` path, every path searched for a missing model.
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass
from pathlib import Path

from google.protobuf import text_format
from google.protobuf.descriptor import FieldDescriptor
from google.protobuf.message import Message

from joshua_core import config_text, legacy
from joshua_core.config_pb2 import JoshuaConfig
from joshua_core.defaults import simulation_backend, simulation_mode, training_plugins
from joshua_core.errors import ConfigError, UsageError
from joshua_core.limits import check_numbers
from joshua_core.options import OptionSet, close_names, field_or_option, sub_message
from joshua_core.resources import PRESETS, resolve_data_path, shipped_file, shipped_names

PRESET_SUFFIX = ".pbtxt"


@dataclass(frozen=True)
class LoadedConfig:
    """A parsed config and where it came from (a preset name or a file path), for messages."""

    message: JoshuaConfig
    source: str
    base_dir: Path | None  # folder relative paths in the file are resolved against first


def preset_names() -> list[str]:
    """Names of the presets the installed plugins ship, sorted."""
    return shipped_names(PRESETS, PRESET_SUFFIX)


def preset_path(name: str) -> Path:
    """Path of preset `name`; an unknown name raises UsageError listing the close ones, and so does one that two
    plugins ship (naming both)."""
    path = shipped_file(PRESETS, f"{name}{PRESET_SUFFIX}")
    if path is not None:
        return path
    names = preset_names()
    close = difflib.get_close_matches(name, names, n=4, cutoff=0.4)
    hint = f" Did you mean: {', '.join(close)}?" if close else ""
    raise UsageError(f"unknown preset '{name}'.{hint}\nAvailable presets: {', '.join(names)}")


def load_preset(name: str, options: OptionSet) -> LoadedConfig:
    """Parse a shipped preset (following its `extends`); `options`: those it may use."""
    return LoadedConfig(_parse_file(preset_path(name), (name,), options), f"preset {name}", None)


def load_file(path: str | Path, options: OptionSet) -> LoadedConfig:
    """Parse a `.pbtxt` config (following its `extends`); `options` as for `load_preset`."""
    file = Path(path)
    if file.is_dir():
        raise UsageError(f"config file '{path}' is a directory; give a .pbtxt file in it")
    if not file.is_file():
        raise UsageError(f"config file '{path}' not found")
    return LoadedConfig(_parse_file(file, (), options), str(file), file.resolve().parent)


# Presets a config may stack through `extends`: far more than any real layering needs, and well below
# Python's recursion limit, which a longer chain would hit as a traceback.
MAX_EXTENDS_DEPTH = 64


def _parse_file(path: Path, seen: tuple[str, ...], options: OptionSet) -> JoshuaConfig:
    """Parse `path`; if it `extends` a preset, parse that first and lay this file over it."""
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise ConfigError(f"{path}: not a text config (byte {error.start} is not UTF-8); expected a .pbtxt") from None
    except OSError as error:
        raise ConfigError(f"{path}: cannot read the config: {error.strerror}") from None
    own = parse_text(text, str(path), options)
    if not own.extends:
        return own
    if own.extends in seen:
        chain = " -> ".join((*seen, own.extends))
        raise ConfigError(f"{path}: presets extend each other in a cycle: {chain}")
    if len(seen) >= MAX_EXTENDS_DEPTH:
        raise ConfigError(f"{path}: extends a chain of more than {MAX_EXTENDS_DEPTH} presets; shorten it")
    merged = _parse_file(preset_path(own.extends), (*seen, own.extends), options)
    _clear_repeated_fields_set_in(own, merged)
    _read_text(text, str(path), merged, options, merge=True, notices=False)  # its notices came with `own`
    merged.ClearField("extends")  # applied; the result stands on its own (e.g. in --print-config)
    return merged


def parse_text(text: str, source: str, options: OptionSet) -> JoshuaConfig:
    """Parse one config text (its `extends` not followed); errors say `source:line:col`."""
    config = JoshuaConfig()
    _read_text(text, source, config, options, merge=False)
    return config


def _read_text(
    text: str, source: str, config: JoshuaConfig, options: OptionSet, *, merge: bool, notices: bool = True
) -> None:
    """Parse (or merge) `text` into `config` after the short-name pass; errors at their original place.
    `notices`: print the notices of old spellings (once per file: not again when it is merged over its preset)."""
    rewritten = config_text.to_protobuf(text, JoshuaConfig.DESCRIPTOR, options, source, notices=notices)
    read = text_format.Merge if merge else text_format.Parse
    try:
        read(rewritten.text, config, allow_unknown_extension=options.lenient, allow_unknown_field=options.lenient)
    except text_format.ParseError as error:
        raise ConfigError(f"{source}:{rewritten.located(error)}") from None
    except ValueError as error:  # a number the parser read but the field cannot hold (an enum's 2**31)
        raise ConfigError(f"{source}: {error}") from None
    _apply_moves(config, rewritten.moves, check=not merge)


def _apply_moves(config: JoshuaConfig, moves: list[config_text.Move], *, check: bool) -> None:
    """Set the new spelling of each moved field its old one wrote (`joshua_core.legacy`). `check`: a new spelling
    the text sets to another value is a ConfigError; a text merged over its preset (checked when it was parsed on
    its own) overrides the preset's value instead."""
    grouped: dict[tuple[str, ...], list[config_text.Move]] = {}
    for move in moves:  # the items of an old list written as several `old: value` lines are one value
        key = (*(entered.full_name for entered in move.path), move.option.full_name, move.new)
        grouped.setdefault(key, []).append(move)
    for group in grouped.values():
        first = group[0]
        target: Message = config
        for entered in first.path:
            target = sub_message(target, entered)
        given = type(target)()
        try:
            text_format.Parse(" ".join(f"{first.new}: {move.text}" for move in group), given)
        except (text_format.ParseError, ValueError) as error:  # ValueError: as in _read_text
            old_path, _ = legacy.moved_paths(first.option, first.old, first.new)
            reason = config_text.bare_message(error) if isinstance(error, text_format.ParseError) else str(error)
            raise ConfigError(f"{first.where}: {old_path}: {reason}") from None
        field = target.DESCRIPTOR.fields_by_name[first.new]
        set_here = any(listed is field for listed, _ in target.ListFields())
        if check and set_here and getattr(target, first.new) != getattr(given, first.new):
            raise ConfigError(f"{first.where}: {legacy.moved_conflict(first.option, first.old, first.new)}")
        target.ClearField(first.new)
        target.MergeFrom(given)
        if not sub_message(target, first.option).ListFields():  # the option held only moved fields: it is unset
            target.ClearExtension(first.option)


def _clear_repeated_fields_set_in(overlay: Message, base: Message) -> None:
    """Empty every repeated field of `base` that `overlay` lists, so the overlay replaces, not appends."""
    for field, value in overlay.ListFields():
        if field.is_repeated:
            _clear(base, field)
        elif field.type == FieldDescriptor.TYPE_MESSAGE:
            _clear_repeated_fields_set_in(value, sub_message(base, field))


def _clear(message: Message, field: FieldDescriptor) -> None:
    if field.is_extension:
        message.ClearExtension(field)
    else:
        message.ClearField(field.name)


def config_text_of(config: JoshuaConfig, options: OptionSet) -> str:
    """The text of `config` as configs are written (options by short names): what `--print-config` shows."""
    return config_text.to_short(text_format.MessageToString(config), JoshuaConfig.DESCRIPTOR, options)


_PATH_PART = re.compile(r"^(?P<name>\w+)(?:\[(?P<index>\d+)\])?$")


def apply_override(config: JoshuaConfig, assignment: str, options: OptionSet) -> None:
    """Apply one `--set path.to.field=value`; list items as `mappings[2].offset=0.1`, options by short name
    (`simulation.offscreen.fps=60`). `options` as for `load_preset`; a lenient set skips unknown names."""
    path, separator, value = assignment.partition("=")
    if not separator or not path:
        raise UsageError(f"--set expects path.to.field=value, got '{assignment}'")
    if path.strip() == "extends":
        raise UsageError("--set extends=... has no effect; put `extends` in a config file or use --preset")
    message: Message = config
    parent: Message = config  # the message `message` is a field of, and that field
    entered: FieldDescriptor | None = None
    parts = path.strip().split(".")
    for depth, part in enumerate(parts):
        match = _PATH_PART.match(part)
        if match and depth == len(parts) - 1 and legacy.is_renamed(message.DESCRIPTOR.full_name, match["name"]):
            _set_renamed(message, value.strip(), assignment, options)
            return
        name = match["name"] if match else part
        new = options.moved_field(entered, name) if depth == len(parts) - 1 else None
        if new is not None and entered is not None:  # an option's field that moved to the message it extends
            if not options.lenient:  # the notice once, by the strict pass (as for a renamed field)
                legacy.moved_notice(f"--set {assignment}", entered, name, new)
            message = parent
        field = field_or_option(message.DESCRIPTOR, new or name, options) if match else None
        if match is None or field is None:
            if options.lenient:
                return
            raise UsageError(_unknown_name(assignment, ".".join(parts[:depth]), message, part, options))
        last = depth == len(parts) - 1
        if last and match["index"] is None:
            if field.type == FieldDescriptor.TYPE_MESSAGE:
                raise UsageError(f"--set {assignment}: '{path}' is a message; set one of its fields instead")
            _merge_field(message, field, value.strip(), assignment)
            return
        if last and field.is_repeated and field.type != FieldDescriptor.TYPE_MESSAGE:
            _set_item(message, field, int(match["index"]), value.strip(), assignment)
            return
        if field.type != FieldDescriptor.TYPE_MESSAGE or last:
            raise UsageError(
                f"--set {assignment}: '{field.name}' is not a list or message: it cannot be indexed or descended into"
            )
        parent, entered = message, field
        message = _descend(message, field, match["index"], assignment)


def _set_renamed(message: Message, value: str, assignment: str, options: OptionSet) -> None:
    """`--set training.framework=SB3`, an old spelling: set the fields it stands for, with the notice naming them."""
    fields = legacy.framework_fields(value)
    if fields is None:
        if options.lenient:
            return
        raise UsageError(f"--set {assignment}: {legacy.unknown_framework(value)}")
    if not options.lenient:  # the CLI's lenient pass comes first: the notice is printed once, by the strict one
        legacy.notice(f"--set {assignment}", value)
    for name, item in fields.items():
        setattr(message, name, item)


def _unknown_name(assignment: str, where: str, message: Message, part: str, options: OptionSet) -> str:
    """The error for a `--set` path part that names no field or option: the close ones, then all of them."""
    descriptor = message.DESCRIPTOR
    listing = f"Fields: {', '.join(sorted(descriptor.fields_by_name))}"
    if options.names(descriptor):
        listing += f"; options: {', '.join(options.names(descriptor))}"
    provider = config_text.provider_hint(part)
    hint = close_names(descriptor, part, options) + (f"{provider}." if provider else "")
    return f"--set {assignment}: {where or descriptor.name} has no field '{part}'.{hint} {listing}"


def _descend(message: Message, field: FieldDescriptor, index: str | None, assignment: str) -> Message:
    """The sub-message `field` (item `index` of a list; one past the end appends a new item)."""
    if not field.is_repeated:
        if index is not None:
            raise UsageError(f"--set {assignment}: '{field.name}' is not a list")
        return sub_message(message, field)
    items = sub_message(message, field)
    if index is None:
        raise UsageError(f"--set {assignment}: '{field.name}' is a list; name an item as {field.name}[N]")
    position = int(index)
    if position > len(items):
        raise UsageError(f"--set {assignment}: {field.name} has {len(items)} items; use an index up to {len(items)}")
    return items.add() if position == len(items) else items[position]


def _set_item(message: Message, field: FieldDescriptor, position: int, value: str, assignment: str) -> None:
    """Set item `position` of a list of scalars (`hidden_sizes[1]=8`); one past the end appends."""
    items = sub_message(message, field)
    if position > len(items):
        raise UsageError(f"--set {assignment}: {field.name} has {len(items)} items; use an index up to {len(items)}")
    scratch = type(message)()  # parse the value alone, with the field's type, enums and quoting
    _merge_field(scratch, field, value, assignment)
    parsed = sub_message(scratch, field)[0]
    if position == len(items):
        items.append(parsed)
    else:
        items[position] = parsed


def _merge_field(message: Message, field: FieldDescriptor, value: str, assignment: str) -> None:
    """Set one scalar field by letting protobuf's text parser read `name: value` (types, enums, quoting)."""
    if field.type == FieldDescriptor.TYPE_STRING and not value.startswith(('"', "'")):
        value = '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if field.is_repeated:
        _clear(message, field)
    name = f"[{field.full_name}]" if field.is_extension else field.name
    try:
        text_format.Merge(f"{name}: {value}", message)
    except text_format.ParseError as error:
        raise UsageError(f"--set {assignment}: {config_text.bare_message(error)}") from None
    except ValueError as error:  # a number the parser read but the field cannot hold (an enum's 2**31)
        raise UsageError(f"--set {assignment}: {error}") from None


def finalize(loaded: LoadedConfig) -> JoshuaConfig:
    """Check the config makes sense and resolve its file paths to absolute ones; return the message."""
    config = loaded.message
    check_numbers(config, loaded.source)  # every number, options included: finite and within bounds
    base_dirs = (loaded.base_dir,) if loaded.base_dir else ()
    if config.operation_mode == JoshuaConfig.SIMULATION:
        simulation = config.simulation
        if not simulation.model_path:
            raise ConfigError(f"{loaded.source}: simulation.model_path is required")
        simulation.model_path = str(resolve_data_path(simulation.model_path, base_dirs=base_dirs))
        if simulation.trajectory_path:
            simulation.trajectory_path = str(
                resolve_data_path(simulation.trajectory_path, base_dirs=base_dirs, what="trajectory", folders=True)
            )
        simulation.backend = simulation_backend(simulation)
        simulation.mode = simulation_mode(simulation)
    else:
        training = config.training
        if not training.model_path:
            raise ConfigError(f"{loaded.source}: training.model_path is required")
        training.model_path = str(resolve_data_path(training.model_path, base_dirs=base_dirs))
        training.trainer, training.backend = training_plugins(training)
    return config


# What `joshua` runs when given neither --preset nor --config: the representative job, headless and short.
# It validates the example trajectory against the SO-ARM100 and records its replay (PASSIVE of joshua-modes,
# which ./setup.sh installs; without it, `joshua` says to install it). The CLI then prints what to try next.
DEFAULT_CONFIG_TEXT = """
description: "Validates the SO-ARM100's example trajectory and records its replay headless: \
joshua_output/passive_replay.mp4 and passive_report.json"
operation_mode: SIMULATION
simulation {
  mode: PASSIVE
  model_path: "so_arm100/scene.xml"
  trajectory_path: "trajectories/so_arm100_example.csv"
  render_width: 320
  render_height: 240
  viewer { display: RECORD fps: 15 }
}
"""


def load_default(options: OptionSet) -> LoadedConfig:
    """The embedded default config; `options` as for `load_preset`."""
    return LoadedConfig(parse_text(DEFAULT_CONFIG_TEXT, "<embedded default>", options), "embedded default", None)
