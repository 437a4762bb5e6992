"""Loading configs: presets and `.pbtxt` files (text-format JoshuaConfig), `extends`, `--set` overrides.

Errors always point at the input: `file:line:col` for parse errors, the close names for an unknown
preset, the field names available for a bad `--set` path, every path searched for a missing model.
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass
from pathlib import Path

from google.protobuf import text_format
from google.protobuf.descriptor import FieldDescriptor
from google.protobuf.message import Message

from joshua_core.config_pb2 import JoshuaConfig, SimulationConfig, TrainingConfig
from joshua_core.errors import ConfigError, UsageError
from joshua_core.plugins import Kind
from joshua_core.resources import presets_dir, resolve_data_path

PRESET_SUFFIX = ".pbtxt"

# The trainer and backend a framework uses when the config leaves them empty.
FRAMEWORK_DEFAULTS: dict[int, tuple[str, str]] = {
    TrainingConfig.MJX: ("ppo", "mjx"),
    TrainingConfig.SB3: ("sb3", "mujoco"),
}
DEFAULT_SIMULATION_BACKEND = "mujoco"
NON_NEGATIVE_TRAINING_FIELDS = (  # num_envs is checked where environments are made (EnvSpec)
    "total_timesteps",
    "num_steps",
    "num_epochs",
    "minibatch_size",
    "learning_rate",
    "gamma",
    "gae_lambda",
    "clip_epsilon",
)


@dataclass(frozen=True)
class LoadedConfig:
    """A parsed config and where it came from (a preset name or a file path), for messages."""

    message: JoshuaConfig
    source: str
    base_dir: Path | None  # folder relative paths in the file are resolved against first


def preset_names() -> list[str]:
    """Names of the shipped presets, sorted."""
    return sorted(path.stem for path in presets_dir().glob(f"*{PRESET_SUFFIX}"))


def preset_path(name: str) -> Path:
    """Path of preset `name`; an unknown name raises UsageError listing the close ones."""
    path = presets_dir() / f"{name}{PRESET_SUFFIX}"
    if path.is_file():
        return path
    names = preset_names()
    close = difflib.get_close_matches(name, names, n=4, cutoff=0.4)
    hint = f" Did you mean: {', '.join(close)}?" if close else ""
    raise UsageError(f"unknown preset '{name}'.{hint}\nAvailable presets: {', '.join(names)}")


def load_preset(name: str) -> LoadedConfig:
    """Parse a shipped preset (following its `extends`)."""
    return LoadedConfig(_parse_file(preset_path(name), seen=(name,)), f"preset {name}", None)


def load_file(path: str | Path) -> LoadedConfig:
    """Parse a `.pbtxt` config (following its `extends`)."""
    file = Path(path)
    if not file.is_file():
        raise UsageError(f"config file '{path}' not found")
    return LoadedConfig(_parse_file(file, seen=()), str(file), file.resolve().parent)


def _parse_file(path: Path, seen: tuple[str, ...]) -> JoshuaConfig:
    """Parse `path`; if it `extends` a preset, parse that first and lay this file over it."""
    text = path.read_text(encoding="utf-8")
    own = _parse_text(text, str(path))
    if not own.extends:
        return own
    if own.extends in seen:
        chain = " -> ".join((*seen, own.extends))
        raise ConfigError(f"{path}: presets extend each other in a cycle: {chain}")
    merged = _parse_file(preset_path(own.extends), seen=(*seen, own.extends))
    _clear_repeated_fields_set_in(own, merged)
    text_format.Merge(text, merged)
    merged.ClearField("extends")  # applied; the result stands on its own (e.g. in --print-config)
    return merged


def _parse_text(text: str, source: str) -> JoshuaConfig:
    config = JoshuaConfig()
    try:
        text_format.Parse(text, config)
    except text_format.ParseError as error:
        raise ConfigError(f"{source}:{error.GetLine()}:{error.GetColumn()}: {_bare_message(error)}") from None
    return config


def _bare_message(error: text_format.ParseError) -> str:
    """ParseError's text without the 'line:col : ' prefix protobuf puts in front."""
    return re.sub(r"^\d+:\d+ : ", "", str(error))


def _clear_repeated_fields_set_in(overlay: Message, base: Message) -> None:
    """Empty every repeated field of `base` that `overlay` lists, so the overlay replaces, not appends."""
    for field, value in overlay.ListFields():
        if field.is_repeated:
            base.ClearField(field.name)
        elif field.type == FieldDescriptor.TYPE_MESSAGE:
            _clear_repeated_fields_set_in(value, getattr(base, field.name))


_PATH_PART = re.compile(r"^(?P<name>\w+)(?:\[(?P<index>\d+)\])?$")


def apply_override(config: JoshuaConfig, assignment: str) -> None:
    """Apply one `--set path.to.field=value`; list items as `mappings[2].offset=0.1`."""
    path, separator, value = assignment.partition("=")
    if not separator or not path:
        raise UsageError(f"--set expects path.to.field=value, got '{assignment}'")
    if path.strip() == "extends":
        raise UsageError("--set extends=... has no effect; put `extends` in a config file or use --preset")
    message: Message = config
    parts = path.strip().split(".")
    for depth, part in enumerate(parts):
        match = _PATH_PART.match(part)
        field = message.DESCRIPTOR.fields_by_name.get(match["name"]) if match else None
        where = ".".join(parts[:depth]) or message.DESCRIPTOR.name
        if match is None or field is None:
            options = sorted(message.DESCRIPTOR.fields_by_name)
            close = difflib.get_close_matches(part, options, n=3)
            hint = f" Did you mean: {', '.join(close)}?" if close else ""
            raise UsageError(f"--set {assignment}: {where} has no field '{part}'.{hint} Fields: {', '.join(options)}")
        last = depth == len(parts) - 1
        if last and match["index"] is None:
            if field.type == FieldDescriptor.TYPE_MESSAGE:
                raise UsageError(f"--set {assignment}: '{path}' is a message; set one of its fields instead")
            _merge_field(message, field, value.strip(), assignment)
            return
        if field.type != FieldDescriptor.TYPE_MESSAGE or last:
            raise UsageError(f"--set {assignment}: '{part}' cannot be indexed or descended into")
        message = _descend(message, field, match["index"], assignment)


def _descend(message: Message, field: FieldDescriptor, index: str | None, assignment: str) -> Message:
    """The sub-message `field` (item `index` of a list; one past the end appends a new item)."""
    if not field.is_repeated:
        if index is not None:
            raise UsageError(f"--set {assignment}: '{field.name}' is not a list")
        return getattr(message, field.name)
    items = getattr(message, field.name)
    if index is None:
        raise UsageError(f"--set {assignment}: '{field.name}' is a list; name an item as {field.name}[N]")
    position = int(index)
    if position > len(items):
        raise UsageError(f"--set {assignment}: {field.name} has {len(items)} items; use an index up to {len(items)}")
    return items.add() if position == len(items) else items[position]


def _merge_field(message: Message, field: FieldDescriptor, value: str, assignment: str) -> None:
    """Set one scalar field by letting protobuf's text parser read `name: value` (types, enums, quoting)."""
    if field.type == FieldDescriptor.TYPE_STRING and not value.startswith(('"', "'")):
        value = '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if field.is_repeated:
        message.ClearField(field.name)
    try:
        text_format.Merge(f"{field.name}: {value}", message)
    except text_format.ParseError as error:
        raise UsageError(f"--set {assignment}: {_bare_message(error)}") from None


def finalize(loaded: LoadedConfig) -> JoshuaConfig:
    """Check the config makes sense and resolve its file paths to absolute ones; return the message."""
    config = loaded.message
    base_dirs = (loaded.base_dir,) if loaded.base_dir else ()
    if config.operation_mode == JoshuaConfig.SIMULATION:
        simulation = config.simulation
        if not simulation.model_path:
            raise ConfigError(f"{loaded.source}: simulation.model_path is required")
        simulation.model_path = str(resolve_data_path(simulation.model_path, base_dirs=base_dirs))
        if simulation.trajectory_path:
            simulation.trajectory_path = str(
                resolve_data_path(simulation.trajectory_path, base_dirs=base_dirs, what="trajectory")
            )
        if simulation.render_width < 0 or simulation.render_height < 0:
            raise ConfigError(f"{loaded.source}: render_width and render_height must not be negative")
        if simulation.duration < 0:
            raise ConfigError(f"{loaded.source}: simulation.duration must not be negative")
        simulation.backend = simulation_backend(simulation)
    else:
        training = config.training
        if not training.model_path:
            raise ConfigError(f"{loaded.source}: training.model_path is required")
        training.model_path = str(resolve_data_path(training.model_path, base_dirs=base_dirs))
        for name in NON_NEGATIVE_TRAINING_FIELDS:
            if getattr(training, name) < 0:
                raise ConfigError(f"{loaded.source}: training.{name} must not be negative")
        training.trainer, training.backend = training_plugins(training)
    return config


def required_components(config: JoshuaConfig) -> list[tuple[Kind, str]]:
    """The plugin components a config needs to run (before or after `finalize`)."""
    if config.operation_mode == JoshuaConfig.SIMULATION:
        mode = SimulationConfig.Mode.Name(config.simulation.mode)
        return [(Kind.MODE, mode), (Kind.BACKEND, simulation_backend(config.simulation))]
    trainer, backend = training_plugins(config.training)
    return [(Kind.TRAINER, trainer), (Kind.BACKEND, backend)]


def simulation_backend(simulation: SimulationConfig) -> str:
    """The backend a simulation uses: the one it names, else the default."""
    return simulation.backend or DEFAULT_SIMULATION_BACKEND


def training_plugins(training: TrainingConfig) -> tuple[str, str]:
    """The (trainer, backend) a training job uses: the ones it names, else its framework's defaults."""
    trainer, backend = FRAMEWORK_DEFAULTS[training.framework]
    return training.trainer or trainer, training.backend or backend


# What `joshua` runs when given neither --preset nor --config: a headless smoke run of the arm at home.
DEFAULT_CONFIG_TEXT = """
description: "Headless physics run of the SO-ARM100 held at home for 5 s: checks the model and reports speed"
operation_mode: SIMULATION
simulation {
  mode: HEADLESS
  model_path: "so_arm100/scene.xml"
  keyframe: "home"
  duration: 5.0
}
"""


def load_default() -> LoadedConfig:
    """The embedded default config."""
    return LoadedConfig(_parse_text(DEFAULT_CONFIG_TEXT, "<embedded default>"), "embedded default", None)
