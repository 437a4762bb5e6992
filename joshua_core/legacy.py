"""Old spellings of config fields that left the core schema, read as their new spelling with a one-line notice.

Configs, `--set` and the `config.json` of old run folders keep working: every loader (`joshua_core.config_text`
for text, `joshua_core.config` for `--set`, `joshua_core.options.parse_dict` for dicts) asks here what an old
field means, so each old spelling has one home.

`training.framework` (an enum `MJX`/`SB3` that chose the default trainer and backend) named plugins in the
core schema; a config now names its `trainer` and `backend`, whose defaults (`joshua_core.defaults`) are what
`framework: MJX`, the old default, meant.

Options that every trainer shares (run name, resume, checkpoint interval, hidden sizes, normalisation) moved from
the trainers' options into `TrainingConfig`: `training { ppo { run_name: "x" } }` is now `training { run_name: "x"
}`. Which fields moved, and under which name, each plugin declares where it registers its options
(`Registrar.add(..., moved={old: new})`, kept by `OptionSet.moved`), rather than a rule read off the names: a
field moves only where the plugin had it (`offpolicy { hidden_sizes: ... }` never existed and stays an error), a
field may change its name on the way (`disable_observation_normalization` is now `disable_normalization`), and
the core names no plugin. This module holds what the loaders do with such a field: its old and new paths, the
notice, and the error when a config sets both, differently.
"""

from __future__ import annotations

import sys

from google.protobuf.descriptor import FieldDescriptor

from joshua_core.config_pb2 import JoshuaConfig

# The trainer and backend each old framework chose when the config named neither.
FRAMEWORKS: dict[str, dict[str, str]] = {
    "MJX": {"trainer": "ppo", "backend": "mjx"},
    "SB3": {"trainer": "sb3", "backend": "mujoco"},
}
FRAMEWORK_NUMBERS = ("MJX", "SB3")  # the enum's values, for a config that wrote the number
# (message full name, old field name) of each old spelling the loaders rewrite.
RENAMED_FIELDS = frozenset({("joshua.TrainingConfig", "framework")})


def is_renamed(message: str, name: str) -> bool:
    """Whether `name` is an old field of the message named `message` (its full name) that the loaders rewrite."""
    return (message, name) in RENAMED_FIELDS


def framework_fields(value: str | int) -> dict[str, str] | None:
    """The fields `framework: value` stood for (by name or number, as protobuf read enums), or None if unknown."""
    if isinstance(value, int) or value.isdigit():
        number = int(value)
        value = FRAMEWORK_NUMBERS[number] if 0 <= number < len(FRAMEWORK_NUMBERS) else ""
    return FRAMEWORKS.get(value)


def new_spelling(fields: dict[str, str]) -> str:
    """`trainer: "sb3" backend: "mujoco"`: the text-format spelling of `fields`."""
    return " ".join(f'{name}: "{value}"' for name, value in fields.items())


def unknown_framework(value: str | int) -> str:
    """The error for a framework value that never existed."""
    return f"training.framework '{value}' is not one of {', '.join(FRAMEWORKS)} (write training.trainer instead)"


def notice(where: str, value: str | int) -> None:
    """Print the one-line notice that `framework: value` (at `where`) is an old spelling, naming the new one."""
    fields = framework_fields(value) or {}
    print(
        f"joshua: notice: {where}: training.framework is gone; framework: {value} is now {new_spelling(fields)}",
        file=sys.stderr,
    )


def moved_paths(extension: FieldDescriptor, old: str, new: str) -> tuple[str, str]:
    """("training.ppo.run_name", "training.run_name"): the paths of an option's field `old` that moved to the field
    `new` of the message the option extends."""
    parent = extension.containing_type
    holders = [f.name for f in JoshuaConfig.DESCRIPTOR.fields if f.message_type is parent]
    prefix = holders[0] if holders else parent.name
    return f"{prefix}.{extension.name}.{old}", f"{prefix}.{new}"


def moved_notice(where: str, extension: FieldDescriptor, old: str, new: str) -> None:
    """Print the one-line notice that the option field `old` (at `where`) is now `new` of the message it extends."""
    old_path, new_path = moved_paths(extension, old, new)
    print(f"joshua: notice: {where}: {old_path} is now {new_path}", file=sys.stderr)


def moved_conflict(extension: FieldDescriptor, old: str, new: str) -> str:
    """The error for a config that sets a moved field both ways with different values."""
    old_path, new_path = moved_paths(extension, old, new)
    return f"{old_path} and {new_path} are both set, differently ({old_path} is the old spelling): keep {new_path}"
