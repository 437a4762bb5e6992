"""Plugin discovery and the component registry of one run.

`PluginHost.discover()` loads every entry point of the group `joshua` into a fresh pluggy
PluginManager (there is no global one), asks each plugin separately what it registers, and keeps
going when a plugin is broken: the problem is recorded against that plugin and reported, the
others still load. Components are looked up by kind and name; a name nobody provides raises an
error that lists what is installed and which distribution would provide it.
"""

from __future__ import annotations

import difflib
import functools
import importlib
import inspect
import os
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any

import pluggy
from google.protobuf.descriptor import FieldDescriptor

from joshua_core import __version__, builtin_plugin, catalog, hookspecs
from joshua_core.errors import ConfigError, PluginLoadError, PluginNotFoundError, UsageError
from joshua_core.interfaces import Backend, Command, EnvKind, Mode, ModelReader, Trainer
from joshua_core.kinds import Kind
from joshua_core.options import OptionSet

ENTRY_POINT_GROUP = "joshua"
DISABLE_ENV_VAR = "JOSHUA_DISABLE_PLUGINS"
CORE_DISTRIBUTION = "joshua-core"


@dataclass
class PluginInfo:
    """One installed plugin as `joshua plugins` shows it."""

    name: str
    distribution: str
    version: str
    module: str
    disabled: bool = False
    error: str | None = None
    components: list[Component] = field(default_factory=list)


@dataclass(frozen=True)
class Component:
    """A registered backend, mode, trainer, task, term, command or option; `target` is the object or its
    "module:attr" path.

    `env_kinds`: the environment kinds (EnvKind values) a backend provides, or a trainer can train on.
    `moved`: an option's old fields that moved to the message it extends, (old name, new name) pairs.
    `settings`: an option's settings function (`joshua_register_options`), or its "module:function" path; None: the
    option's message is its settings.
    """

    kind: Kind
    name: str
    target: object
    summary: str
    plugin: PluginInfo
    env_kinds: tuple[str, ...] = ()
    moved: tuple[tuple[str, str], ...] = ()
    settings: object = None

    def load(self) -> Any:
        """Import the target if it is still a path; a failure names the plugin and the cause."""
        return self._import(self.target)

    def load_settings(self) -> Callable[[Any, Any], Any] | None:
        """Import the settings function if it is still a path (None: the option registered none)."""
        return self._import(self.settings) if self.settings is not None else None

    def _import(self, target: object) -> Any:
        """`target` itself, or the object its "module:attr" path names; a failure names the plugin and the cause."""
        if not isinstance(target, str):
            return target
        module_name, _, attribute_path = target.partition(":")
        owner = f"{self.kind.value} '{self.name}' from plugin '{self.plugin.name}' ({self.plugin.distribution})"
        try:
            return functools.reduce(getattr, attribute_path.split("."), importlib.import_module(module_name))
        except ModuleNotFoundError as error:
            if error.name and (module_name == error.name or module_name.startswith(f"{error.name}.")):
                raise PluginLoadError(f"{owner} names module '{module_name}', which does not exist") from error
            raise PluginLoadError(
                f"{owner} cannot be loaded: missing module '{error.name}'. Reinstall the plugin with its "
                f"dependencies: pip install --force-reinstall {self.plugin.distribution}"
            ) from error
        except Exception as error:  # a plugin's import can fail in any way; report it, don't crash
            raise PluginLoadError(f"{owner} failed to load {target}: {type(error).__name__}: {error}") from error


class Registrar:
    """Handed to one plugin's registration hook; records what that plugin provides of one kind."""

    def __init__(self, kind: Kind, plugin: PluginInfo) -> None:
        self.kind = kind
        self.plugin = plugin
        self.added: list[Component] = []

    def add(
        self,
        name: str,
        target: object,
        summary: str = "",
        *,
        env_kinds: Iterable[str] = (),
        moved: Mapping[str, str] | None = None,
        settings: object = None,
    ) -> None:
        """Register `target` (an object, or a "module:attr" path imported on first use) as `name`.

        `env_kinds` (backends and trainers only): the EnvKind values ("numpy", "jax") a backend provides,
        or a trainer can train on; declared here so that they are checked without importing anything.
        `moved` (options only): {old name: new name} of the option's fields that moved to the message it extends,
        which old configs still write in the option (`joshua_core.legacy`).
        `settings` (options only): the function that turns the option into its typed settings, or its
        "module:function" path imported on first use (`joshua_register_options` says what it takes).
        """
        if not isinstance(name, str) or not name:
            raise TypeError(f"{self.kind.value} name must be a non-empty string, got {name!r}")
        for path in (target, settings):
            if isinstance(path, str) and ":" not in path:
                raise ValueError(
                    f"{self.kind.value} '{name}': target path must look like 'module:attribute', got {path!r}"
                )
        if any(component.name == name for component in self.added):
            raise ValueError(f"{self.kind.value} '{name}' registered twice by the same plugin")
        kinds = (env_kinds,) if isinstance(env_kinds, str) else tuple(env_kinds)
        known = [kind.value for kind in EnvKind]
        if kinds and self.kind not in (Kind.BACKEND, Kind.TRAINER):
            raise ValueError(f"{self.kind.value} '{name}': only backends and trainers declare env_kinds")
        if unknown := [kind for kind in kinds if kind not in known]:
            raise ValueError(f"{self.kind.value} '{name}': unknown env_kinds {unknown}; known: {', '.join(known)}")
        if moved and self.kind is not Kind.OPTIONS:
            raise ValueError(f"{self.kind.value} '{name}': only options declare moved fields")
        if settings is not None and self.kind is not Kind.OPTIONS:
            raise ValueError(f"{self.kind.value} '{name}': only options register settings")
        renames = tuple(sorted((moved or {}).items()))
        self.added.append(Component(self.kind, name, target, summary, self.plugin, kinds, renames, settings))


def _normalized(name: str) -> str:
    """Plugin and distribution names compare case-insensitively, with `-`, `_` and `.` alike."""
    return name.strip().lower().replace("_", "-").replace(".", "-")


class PluginHost:
    """The plugins of one run and everything they registered."""

    def __init__(self, plugins: Iterable[tuple[PluginInfo, object]]) -> None:
        """Register already-imported plugin objects (entry-point modules, or any object with hookimpls)."""
        self.plugins: list[PluginInfo] = []
        self._components: dict[tuple[Kind, str], Component] = {}
        self._conflicts: dict[tuple[Kind, str], list[PluginInfo]] = {}
        self._options: OptionSet | None = None
        self._manager = pluggy.PluginManager(hookspecs.PROJECT_NAME)
        self._manager.add_hookspecs(hookspecs)
        for info, plugin in plugins:
            self.plugins.append(info)
            if info.disabled or info.error:
                continue
            try:
                self._manager.register(plugin, name=info.name)
                self._manager.check_pending()  # a misspelled hook name is an error, not silence
                components = self._registrations_of(info, plugin)
            except Exception as error:  # a plugin can fail in any way; record it and drop what it registered
                info.error = str(error) if isinstance(error, PluginLoadError) else f"{type(error).__name__}: {error}"
                if self._manager.is_registered(plugin):
                    self._manager.unregister(plugin)
                continue
            info.components = components
            for component in components:
                self._file(component)

    @classmethod
    def discover(cls, disabled: Iterable[str] | None = None) -> PluginHost:
        """Load the built-in plugin and every installed entry point of the group `joshua`.

        `disabled` names plugins (entry-point or distribution names; `-` and `_` alike) to skip; by
        default it is read from the comma-separated environment variable JOSHUA_DISABLE_PLUGINS.
        The built-in plugin "core" cannot be disabled.
        """
        if disabled is None:
            disabled = os.environ.get(DISABLE_ENV_VAR, "").split(",")
        skip = {_normalized(name) for name in disabled if name.strip()}
        entries: list[tuple[PluginInfo, object]] = [
            (PluginInfo("core", CORE_DISTRIBUTION, __version__, builtin_plugin.__name__), builtin_plugin)
        ]
        for entry_point in sorted(metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda ep: ep.name):
            distribution = entry_point.dist.name if entry_point.dist else "unknown"
            version = entry_point.dist.version if entry_point.dist else "?"
            info = PluginInfo(entry_point.name, distribution, version, entry_point.value)
            info.disabled = bool({_normalized(entry_point.name), _normalized(distribution)} & skip)
            module: object = None
            if not info.disabled:
                try:
                    module = entry_point.load()
                except Exception as error:  # a broken plugin must not stop the others
                    info.error = f"{type(error).__name__}: {error}"
            entries.append((info, module))
        return cls(entries)

    def _registrations_of(self, info: PluginInfo, plugin: object) -> list[Component]:
        """Call each registration hook of one plugin (only that plugin's) and return what it registered."""
        others = [p for p in self._manager.get_plugins() if p is not plugin]
        components: list[Component] = []
        for kind in Kind:
            registrar = Registrar(kind, info)
            try:
                self._manager.subset_hook_caller(kind.hook_name, remove_plugins=others)(registry=registrar)
            except Exception as error:  # a plugin's hook can fail in any way
                raise PluginLoadError(f"{kind.hook_name} raised {type(error).__name__}: {error}") from error
            components += registrar.added
        return components

    def _file(self, component: Component) -> None:
        """Make a component usable by name, or record a conflict with another plugin's."""
        key = (component.kind, component.name)
        if key in self._conflicts:
            self._conflicts[key].append(component.plugin)
        elif key in self._components:
            self._conflicts[key] = [self._components.pop(key).plugin, component.plugin]
        else:
            self._components[key] = component

    @property
    def conflicts(self) -> list[str]:
        """One line per name registered by more than one plugin."""
        return [self._conflict_message(kind, name) for kind, name in self._conflicts]

    @property
    def problems(self) -> list[str]:
        """One line per broken plugin, then the conflicts."""
        broken = [
            f"plugin '{info.name}' ({info.distribution} {info.version}) is broken: {info.error}"
            for info in self.plugins
            if info.error
        ]
        return broken + self.conflicts

    def _conflict_message(self, kind: Kind, name: str) -> str:
        providers = self._conflicts[(kind, name)]
        names = " and ".join(f"'{info.name}' ({info.distribution})" for info in providers)
        disable = " or ".join(f"{DISABLE_ENV_VAR}={info.name}" for info in providers)
        return (
            f"{kind.value} '{name}' is registered by both {names}; "
            f"it is unusable until one is removed or disabled ({disable})"
        )

    def names(self, kind: Kind) -> list[str]:
        """Sorted names of the usable components of one kind."""
        return sorted(name for k, name in self._components if k is kind)

    def component(self, kind: Kind, name: str) -> Component:
        """The registered component, or an error saying what to install or fix."""
        key = (kind, name)
        if key in self._components:
            return self._components[key]
        if key in self._conflicts:
            raise UsageError(self._conflict_message(kind, name))
        raise PluginNotFoundError(self.missing_message(kind, name))

    def missing_message(self, kind: Kind, name: str) -> str:
        """Why `name` is unavailable: which distribution provides it, and what is installed instead."""
        message = f"no {kind.value} named '{name}' is installed."
        provider = catalog.provider(kind, name)
        installed = {info.distribution: info for info in self.plugins}
        if provider and provider in installed and installed[provider].disabled:
            message += f" It comes from {provider}, which is disabled by {DISABLE_ENV_VAR}."
        elif provider and provider in installed and installed[provider].error:
            message += f" It comes from {provider}, which is installed but broken: {installed[provider].error}"
        elif provider:
            message += (
                f" Install the plugin that provides it: pip install {provider}"
                f" (from a source checkout: pip install -e plugins/{provider})"
            )
        else:
            close = difflib.get_close_matches(name, self.names(kind), n=3)
            if close:
                message += f" Did you mean: {', '.join(close)}?"
        available = ", ".join(self.names(kind)) or "none"
        return f"{message} Installed {kind.value}s: {available}"  # one line, as every user error

    def check_env_kinds(self, trainer: str, backend: str, needs: Iterable[EnvKind] | None = None) -> None:
        """Raise ConfigError unless `backend` provides one of the environment kinds `trainer` needs (`needs`,
        else those the trainer declared; a trainer that declared none is not checked), naming the backends
        that do. Reads only the registrations: nothing is imported."""
        wanted = [kind.value for kind in needs] if needs is not None else self._declared(Kind.TRAINER, trainer)
        if not wanted or set(wanted) & set(self.component(Kind.BACKEND, backend).env_kinds):
            return
        kinds = " or ".join(kind.upper() for kind in wanted)
        able = [name for name in self.names(Kind.BACKEND) if set(wanted) & set(self._declared(Kind.BACKEND, name))]
        raise ConfigError(
            f"trainer '{trainer}' needs {kinds} environments, which backend '{backend}' does not provide; "
            f"backends that do: {', '.join(able) or 'none installed'}"
        )

    def _declared(self, kind: Kind, name: str) -> tuple[str, ...]:
        component = self._components.get((kind, name))
        return component.env_kinds if component else ()

    def create(self, kind: Kind, name: str, base: type[Any]) -> Any:
        """Instantiate the registered class `name`, checking that it implements `base` (an ABC)."""
        component = self.component(kind, name)
        target = component.load()
        owner = f"{kind.value} '{name}' from plugin '{component.plugin.name}' ({component.plugin.distribution})"
        if not (isinstance(target, type) and issubclass(target, base)):
            raise PluginLoadError(f"{owner} is {target!r}, not a subclass of {base.__module__}.{base.__qualname__}")
        mismatch = next(_signature_mismatches(target, base), None)
        if mismatch is not None:
            raise PluginLoadError(f"{owner}: {mismatch}; the plugin was written for another joshua-core: update it")
        return target()

    def backend(self, name: str) -> Backend:
        return self.create(Kind.BACKEND, name, Backend)

    def mode(self, name: str) -> Mode:
        return self.create(Kind.MODE, name, Mode)

    def trainer(self, name: str) -> Trainer:
        return self.create(Kind.TRAINER, name, Trainer)

    def command(self, name: str) -> Command:
        return self.create(Kind.COMMAND, name, Command)

    def model_reader(self, suffix: str) -> ModelReader:
        return self.create(Kind.READER, suffix, ModelReader)

    def options(self) -> OptionSet:
        """The registered options, their `_pb2` modules imported (light: they import only protobuf and the core
        schema). A plugin whose option is not an extension of its short name (or does not import) is marked broken
        with a message naming it, and everything it registered is dropped, as for any broken plugin."""
        if self._options is None:
            loaded = []
            for name in self.names(Kind.OPTIONS):
                component = self.component(Kind.OPTIONS, name)
                try:
                    loaded.append((component, _extension_of(component)))
                except PluginLoadError as error:
                    self._drop_broken(component.plugin, str(error))
            usable = [(component, option) for component, option in loaded if not component.plugin.error]
            self._options = OptionSet(
                tuple(option for _, option in usable),
                moved={option.full_name: dict(component.moved) for component, option in usable if component.moved},
            )
        return self._options

    def _drop_broken(self, plugin: PluginInfo, error: str) -> None:
        """Record `plugin` as broken and forget everything it registered."""
        plugin.error = error
        self._components = {key: c for key, c in self._components.items() if c.plugin is not plugin}


def _signature_mismatches(target: type, base: type) -> Iterator[str]:
    """What differs, for each public method of the ABC `base` that `target` overrides with parameters the core's
    calls do not fit (e.g. a backend written before `create_engine` took the run's plugins), where calling it would
    be a TypeError traceback from inside the core."""
    for method, declared in vars(base).items():
        implemented = getattr(target, method, None)
        if method.startswith("_") or not inspect.isfunction(declared) or implemented is declared:
            continue
        try:
            expected, actual = inspect.signature(declared), inspect.signature(implemented)  # type: ignore[arg-type]
        except (TypeError, ValueError):  # not introspectable (a builtin, a callable object): nothing to compare
            continue
        passed = [p for p in expected.parameters.values() if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
        try:
            actual.bind(
                *(p.name for p in passed if p.kind is not p.KEYWORD_ONLY),
                **{p.name: None for p in passed if p.kind is p.KEYWORD_ONLY},
            )
        except TypeError as error:
            names = [p.name for p in passed]
            lacks = [f"lacks '{name}'" for name in names if name not in actual.parameters]
            needs = [
                f"requires '{name}', which the core does not pass"
                for name, p in actual.parameters.items()
                if name not in names and p.default is p.empty and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
            ]
            yield (
                f"{method}{_unannotated(actual)} does not fit joshua-core {__version__}'s "
                f"{base.__qualname__}.{method}{_unannotated(expected)}: it {', '.join(lacks + needs) or error}"
            )


def _unannotated(signature: inspect.Signature) -> inspect.Signature:
    """`signature` without its annotations, as a message shows it (names and defaults)."""
    parameters = [parameter.replace(annotation=parameter.empty) for parameter in signature.parameters.values()]
    return signature.replace(parameters=parameters, return_annotation=signature.empty)


def _extension_of(component: Component) -> FieldDescriptor:
    """The protobuf extension an option component names; anything else is a PluginLoadError naming the plugin."""
    target = component.load()
    name = component.name
    owner = f"option '{name}' from plugin '{component.plugin.name}' ({component.plugin.distribution})"
    if not (isinstance(target, FieldDescriptor) and target.is_extension and target.name == name):
        raise PluginLoadError(
            f"{owner} is {target!r}, not a protobuf extension named '{name}' (e.g. \"my_plugin.options_pb2:{name}\")"
        )
    for old, new in component.moved:
        if target.message_type is None or old in target.message_type.fields_by_name:
            raise PluginLoadError(f"{owner} declares '{old}' moved, but its message still has it (or is no message)")
        if new not in target.containing_type.fields_by_name:
            parent = target.containing_type.name
            raise PluginLoadError(f"{owner} declares '{old}' moved to {parent}.{new}, which does not exist")
    return target
