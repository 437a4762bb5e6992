"""The config loader's text pass: plugin options under their short names, bare mode names.

Protobuf's text format names an extension in brackets (`[joshua_modes.offscreen] { fps: 30 }`) and
wants a string value quoted. Configs and presets read as they always have (`offscreen { fps: 30 }`,
`mode: OFFSCREEN`), so before parsing, `to_protobuf` walks the text with protobuf's own tokenizer,
tracking the message type at each nesting level, and rewrites

- a name that is not a field of its message but a registered option (extension) of it into
  `[full.name]` (a name that is neither is reported here, with the close ones, unless lenient);
- a bare identifier after `mode:` in `simulation` into a quoted string;
- an old spelling of a field that left the core schema (`framework: SB3`) into its new one
  (`joshua_core.legacy`), naming it in a one-line notice unless lenient (the CLI's first, lenient, pass
  rewrites it too, without the notice, so that the notice is printed once);
- an option's old field that moved to the message the option extends (`ppo { run_name: "x" }`, declared by the
  plugin: `OptionSet.moved`) out of the text, into a `Move` the loader applies after parsing
  (`Rewritten.moves`), naming the new spelling in a one-line notice.

Each edit is recorded, so that an error protobuf finds in the rewritten text is reported at its place
in the original (`Rewritten.located`). `to_short` does the reverse for `--print-config`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from google.protobuf import text_format
from google.protobuf.descriptor import Descriptor, FieldDescriptor

from joshua_core import catalog, legacy
from joshua_core.errors import ConfigError
from joshua_core.kinds import Kind
from joshua_core.options import OptionSet, close_names, field_or_option

# String fields whose values configs may write bare, as enum values are (`mode: HEADLESS`; docs/configuration.md).
BARE_STRING_FIELDS = frozenset({"joshua.SimulationConfig.mode"})
_BARE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_QUOTED_BARE = re.compile(r'^"([A-Za-z_][A-Za-z0-9_]*)"$')
_CLOSING = {"{": "}", "<": ">"}


@dataclass(frozen=True)
class Edit:
    """`length` characters at (`line`, `column`) of the original text (both from 0) become `text`."""

    line: int
    column: int
    length: int
    text: str


@dataclass(frozen=True)
class Move:
    """An option's old field `old`, written `old: text` in the option at `where`, whose new spelling is the field
    `new` of the message the option extends, found from the root by `path`."""

    path: tuple[FieldDescriptor, ...]
    option: FieldDescriptor
    old: str
    new: str
    text: str
    where: str


@dataclass
class Rewritten:
    """A rewritten text, the edits that made it from the original, and the moved fields it took out."""

    original: str
    edits: list[Edit] = field(default_factory=list)
    moves: list[Move] = field(default_factory=list)

    @property
    def text(self) -> str:
        lines = self.original.split("\n")
        for edit in sorted(self.edits, key=lambda e: (e.line, e.column), reverse=True):
            line = lines[edit.line]
            lines[edit.line] = line[: edit.column] + edit.text + line[edit.column + edit.length :]
        return "\n".join(lines)

    def located(self, error: text_format.ParseError) -> str:
        """`line:col: message` of a ParseError in the rewritten text, as a place and a quote of the original."""
        message = bare_message(error)
        if error.GetLine() is None:
            return message
        line, column = self._original_position(error.GetLine(), error.GetColumn() or 1)
        rewritten_line, original_line = self.text.split("\n")[line - 1], self.original.split("\n")[line - 1]
        quoted = f"'{rewritten_line}': "  # the tokenizer quotes the line it is on
        if message.startswith(quoted):
            message = f"'{original_line}': " + message.removeprefix(quoted)
        return f"{line}:{column}: {message}"

    def _original_position(self, line: int, column: int) -> tuple[int, int]:
        """Where (1-based `line`, `column`) of the rewritten text was in the original (inside an edit: its start)."""
        shift = 0
        for edit in sorted((e for e in self.edits if e.line == line - 1), key=lambda e: e.column):
            start = edit.column + shift
            if column - 1 < start:
                break
            if column - 1 < start + len(edit.text):
                return line, edit.column + 1
            shift += len(edit.text) - edit.length
        return line, column - shift


def bare_message(error: text_format.ParseError) -> str:
    """ParseError's text without the 'line:col : ' prefix protobuf puts in front."""
    return re.sub(r"^\d+(:\d+)? : ", "", str(error))


class _Walker:
    """Walks text-format tokens, tracking the message type each name and value belongs to.

    Subclasses see each field name (`name`), bracketed extension name (`extension`) and scalar value
    (`scalar`) and record edits. Text protobuf will reject is walked on tolerantly: the parser reports it.
    """

    def __init__(self, text: str, root: Descriptor, options: OptionSet) -> None:
        self.rewritten = Rewritten(text)
        self.options = options
        self.names: list[set[str]] = []  # the field names of each open message, innermost last
        self.fields: list[FieldDescriptor | None] = []  # the field each open message is the value of (root: None)
        self._tokens = text_format.Tokenizer(text.split("\n"))
        self._message(root, closing=None)

    def name(self, message: Descriptor, name: str, at: tuple[int, int]) -> FieldDescriptor | None:
        return message.fields_by_name.get(name)

    def extension(self, message: Descriptor, full_name: str, at: tuple[int, int], end: int) -> FieldDescriptor | None:
        return self.options.find(message, full_name)

    def scalar(self, message_field: FieldDescriptor, token: str, at: tuple[int, int]) -> None:
        return None

    def renamed(self, message: Descriptor, name: str, value: str, spans: list[tuple[int, int, int]]) -> None:
        """An old field `name: value` of `message` (`joshua_core.legacy`); `spans`: (line, column, length) of
        its name, colon and value."""
        return None

    def moved(self, old: str, new: str, text: str, spans: list[tuple[int, int, int]]) -> None:
        """An old field `old: text` of the innermost open option (`self.fields[-1]`) that moved to the field `new`
        of the message the option extends; `spans`: (line, column, length) of each of its tokens."""
        return None

    def closed(self, message: Descriptor | None) -> None:
        """The message just ended; `self.names[-1]` holds the names it set."""
        return None

    def edit(self, at: tuple[int, int], length: int, text: str) -> None:
        self.rewritten.edits.append(Edit(at[0], at[1], length, text))

    def _position(self) -> tuple[int, int]:
        """(line, column) of the current token, from 0; the tokenizer tells positions only through its errors."""
        error = self._tokens.ParseError("")
        return error.GetLine() - 1, error.GetColumn() - 1

    def _advance(self) -> str:
        token = self._tokens.token
        self._tokens.NextToken()
        return token

    def _message(self, message: Descriptor | None, closing: str | None, entered: FieldDescriptor | None = None) -> None:
        self.names.append(set())
        self.fields.append(entered)
        while not self._tokens.AtEnd():
            if self._tokens.token == closing:
                self._advance()
                break
            if self._tokens.token in (",", ";"):
                self._advance()
            else:
                self._field(message)
        self.closed(message)
        self.names.pop()
        self.fields.pop()

    def _field(self, message: Descriptor | None) -> None:
        at = self._position()
        if self._tokens.token == "[":
            self._advance()
            parts = []
            while not self._tokens.AtEnd() and self._tokens.token != "]":
                parts.append(self._advance())
            end_line, end_column = self._position()
            self._tokens.TryConsume("]")
            end = end_column + 1 if end_line == at[0] else -1  # -1: the brackets span lines
            found = self.extension(message, "".join(parts), at, end) if message is not None else None
        elif _BARE.match(self._tokens.token):
            name = self._advance()
            self.names[-1].add(name)
            if message is not None and legacy.is_renamed(message.full_name, name):
                self._renamed(message, name, at)
                return
            new = self.options.moved_field(self.fields[-1], name) if message is not None else None
            if new is not None:
                self._moved(name, new, at)
                return
            found = self.name(message, name, at) if message is not None else None
        else:
            self._advance()  # not a field name: protobuf reports it
            return
        self._tokens.TryConsume(":")
        self._value(found)

    def _renamed(self, message: Descriptor, name: str, at: tuple[int, int]) -> None:
        """Read an old field's `: value` (a scalar) and hand its parts to `renamed`."""
        spans = [(*at, len(name))]
        if self._tokens.token == ":":
            spans.append((*self._position(), 1))
            self._advance()
        if self._tokens.AtEnd() or self._tokens.token in ("}", ">", "{", "<", "["):
            return  # not a scalar: left for protobuf to report
        spans.append((*self._position(), len(self._tokens.token)))
        self.renamed(message, name, self._advance(), spans)

    def _moved(self, name: str, new: str, at: tuple[int, int]) -> None:
        """Read a moved field's `: value` (a scalar or a `[...]` list of them) and hand its tokens to `moved`."""
        spans = [(*at, len(name))]
        if self._tokens.token == ":":
            spans.append((*self._position(), 1))
            self._advance()
        values: list[str] = []
        depth = 0
        while not self._tokens.AtEnd() and (depth or not values):
            token = self._tokens.token
            if token in ("}", ">", "{", "<") or (token == "]" and not depth):
                return  # not a scalar or a list of them: left for protobuf to report
            depth += {"[": 1, "]": -1}.get(token, 0)
            spans.append((*self._position(), len(token)))
            values.append(self._advance())
        self.moved(name, new, " ".join(values), spans)

    def _value(self, found: FieldDescriptor | None) -> None:
        token = self._tokens.token
        if token in _CLOSING:
            self._advance()
            self._message(found.message_type if found is not None else None, _CLOSING[token], found)
        elif token == "[":  # a list: values or messages, separated by commas
            self._advance()
            while not self._tokens.AtEnd() and not self._tokens.TryConsume("]"):
                if self._tokens.token in ("}", ">"):
                    return  # an unclosed list: protobuf reports it
                if not self._tokens.TryConsume(","):
                    self._value(found)
        elif not self._tokens.AtEnd() and token not in ("}", ">", "]"):
            at = self._position()
            self._advance()
            if found is not None:
                self.scalar(found, token, at)


class _ToProtobuf(_Walker):
    def __init__(self, text: str, root: Descriptor, options: OptionSet, source: str, notices: bool) -> None:
        self.source = source
        self.notices = notices and not options.lenient
        # Per open message: the old fields in it, each as its new fields and the spans it takes.
        self._renames: list[list[tuple[dict[str, str], list[tuple[int, int, int]]]]] = []
        super().__init__(text, root, options)

    def renamed(self, message: Descriptor, name: str, value: str, spans: list[tuple[int, int, int]]) -> None:
        where = f"{self.source}:{spans[0][0] + 1}:{spans[0][1] + 1}"
        fields = legacy.framework_fields(value)
        if fields is None and not self.options.lenient:
            raise ConfigError(f"{where}: {legacy.unknown_framework(value)}")
        if self.notices:
            legacy.notice(where, value)
        self._renames[-1].append((fields or {}, spans))

    def moved(self, old: str, new: str, text: str, spans: list[tuple[int, int, int]]) -> None:
        option = self.fields[-1]
        assert option is not None  # a moved field is one of an option's
        where = f"{self.source}:{spans[0][0] + 1}:{spans[0][1] + 1}"
        if self.notices:
            legacy.moved_notice(where, option, old, new)
        path = tuple(entered for entered in self.fields[1:-1] if entered is not None)
        self.rewritten.moves.append(Move(path, option, old, new, text, where))
        for line, column, length in spans:
            self.edit((line, column), length, "")

    def closed(self, message: Descriptor | None) -> None:
        # The new fields are those the old one stood for that the message does not set itself.
        for fields, spans in self._renames.pop():
            unset = {name: value for name, value in fields.items() if name not in self.names[-1]}
            for index, (line, column, length) in enumerate(spans):
                self.edit((line, column), length, legacy.new_spelling(unset) if index == 0 else "")

    def _message(self, message: Descriptor | None, closing: str | None, entered: FieldDescriptor | None = None) -> None:
        self._renames.append([])
        super()._message(message, closing, entered)

    def name(self, message: Descriptor, name: str, at: tuple[int, int]) -> FieldDescriptor | None:
        found = field_or_option(message, name, self.options)
        if found is not None and found.is_extension:
            self.edit(at, len(name), f"[{found.full_name}]")
        elif found is None and not self.options.lenient:
            raise ConfigError(
                f"{self.source}:{at[0] + 1}:{at[1] + 1}: {message.name} has no field or option named "
                f'"{name}".{close_names(message, name, self.options)}{provider_hint(name)}'
            )
        return found

    def extension(self, message: Descriptor, full_name: str, at: tuple[int, int], end: int) -> FieldDescriptor | None:
        found = self.options.find(message, full_name)
        if found is None:
            try:
                return message.file.pool.FindExtensionByName(full_name)
            except KeyError:
                return None  # protobuf reports it, unless lenient
        return found

    def scalar(self, message_field: FieldDescriptor, token: str, at: tuple[int, int]) -> None:
        if message_field.full_name in BARE_STRING_FIELDS and _BARE.match(token):
            self.edit(at, len(token), f'"{token}"')


class _ToShort(_Walker):
    def extension(self, message: Descriptor, full_name: str, at: tuple[int, int], end: int) -> FieldDescriptor | None:
        found = self.options.find(message, full_name)
        if found is not None and end > 0 and message.fields_by_name.get(found.name) is None:
            self.edit(at, end - at[1], found.name)
        return found

    def scalar(self, message_field: FieldDescriptor, token: str, at: tuple[int, int]) -> None:
        bare = _QUOTED_BARE.match(token)
        if message_field.full_name in BARE_STRING_FIELDS and bare:
            self.edit(at, len(token), bare[1])


def provider_hint(name: str) -> str:
    """' It is an option of joshua-x: install it ...' when a first-party plugin provides `name`."""
    provider = catalog.provider(Kind.OPTIONS, name)
    if provider is None:
        return ""
    return f" '{name}' is an option of {provider}, which is not installed or is disabled: pip install {provider}"


def to_protobuf(text: str, root: Descriptor, options: OptionSet, source: str, *, notices: bool = True) -> Rewritten:
    """`text` as protobuf's parser reads it: options bracketed, bare modes quoted, old spellings in their new one
    or taken out as moves (with a notice when `notices` and not lenient); unknown names are located ConfigErrors
    unless `options` is lenient."""
    return _ToProtobuf(text, root, options, source, notices).rewritten


def to_short(text: str, root: Descriptor, options: OptionSet) -> str:
    """Protobuf's text of a `root` message as configs write it: options by their short names, modes bare."""
    return _ToShort(text, root, options).rewritten.text
