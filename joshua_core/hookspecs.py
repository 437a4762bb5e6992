"""The hooks a JOSHUA plugin implements. Each one only *registers* components; none does work.

A plugin is a module named by an entry point in the group `joshua`, e.g. in its pyproject.toml:

    [project.entry-points.joshua]
    mujoco = "joshua_mujoco.plugin"

and implements any of the hooks below with `@joshua_core.hookimpl`. That module must import
nothing heavy (no mujoco, jax, torch, pxr): it names its classes as "module:attribute" strings,
which JOSHUA imports only when a run needs them, so one broken stack can't break the CLI.

Every hook is called by `joshua_core.plugins.PluginHost` while it is being built (once per run,
for each plugin separately so that the host knows who registered what), receives a `Registrar`
for one kind of component, and returns None. A hook that raises, or a misspelled hook name, marks
its plugin broken and drops everything that plugin registered; the other plugins still load.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import pluggy

if TYPE_CHECKING:
    from joshua_core.plugins import Registrar

PROJECT_NAME = "joshua"

hookspec = pluggy.HookspecMarker(PROJECT_NAME)
hookimpl = pluggy.HookimplMarker(PROJECT_NAME)


@hookspec
def joshua_register_backends(registry: Registrar) -> None:
    """Register physics backends: `registry.add(name, target, summary)`.

    Called by PluginHost when it is built. `target` is a `joshua_core.interfaces.Backend` subclass
    or its "module:Class" path; `name` is what configs put in `backend` (e.g. "mujoco", "mjx").
    `env_kinds=("numpy",)` declares the environment kinds (EnvKind values) its `create_envs` provides.
    """


@hookspec
def joshua_register_modes(registry: Registrar) -> None:
    """Register simulation modes: `registry.add(name, target, summary)`.

    Called by PluginHost when it is built. `name` is what configs put in `simulation.mode`
    (upper case by convention, e.g. "OFFSCREEN"); `target` is a `joshua_core.interfaces.Mode`
    subclass or its path. A mode's own settings are an option (`joshua_register_options`).
    """


@hookspec
def joshua_register_trainers(registry: Registrar) -> None:
    """Register trainers: `registry.add(name, target, summary)`.

    Called by PluginHost when it is built. `name` is what `TrainingConfig.trainer` names
    (e.g. "ppo", "sb3"); `target` is a `joshua_core.interfaces.Trainer` subclass or its path.
    `env_kinds=("jax",)` declares the environment kinds (EnvKind values) it can train on, so that a
    backend without them is reported before anything is imported.
    """


@hookspec
def joshua_register_tasks(registry: Registrar) -> None:
    """Register tasks (environments built from terms): `registry.add(name, target, summary)`.

    Called by PluginHost when it is built. `name` is what `TrainingConfig.task` names
    (e.g. "ant_locomotion"); `target` is a `joshua_core.tasks.TaskSpec`, a function without
    arguments that returns one, or its path. See docs/tasks.md.
    """


@hookspec
def joshua_register_terms(registry: Registrar) -> None:
    """Register task terms: `registry.add(name, target, summary)`.

    Called by PluginHost when it is built. `target` is a term function
    `quantity_kernel(ctx, **params)` of a `joshua_core.tasks.TermContext` (see
    `joshua_core.interfaces.Term` and docs/tasks.md) or its path; tasks and configs refer to it
    by `name`.
    """


@hookspec
def joshua_register_commands(registry: Registrar) -> None:
    """Register `joshua` subcommands: `registry.add(name, target, summary)`.

    Called by PluginHost when it is built. `name` is the subcommand (e.g. "mirror-replay", "eval");
    `summary` is its one-line help; `target` is a `joshua_core.interfaces.Command` subclass or its
    path, imported only when that subcommand runs.
    """


@hookspec
def joshua_register_options(registry: Registrar) -> None:
    """Register config options: `registry.add(name, target, summary)`.

    Called by PluginHost when it is built. `target` is the "module:attribute" path of a protobuf
    extension of `joshua.SimulationConfig` or `joshua.TrainingConfig` that the plugin declares in a
    .proto of its own (e.g. "joshua_modes.options_pb2:offscreen"); `name` is the extension's short
    name, which configs, `--set` and `--print-config` use as if it were a field of the message it
    extends (`simulation { offscreen { fps: 30 } }`). The CLI imports the targets (`PluginHost.options`)
    before it parses a config strictly, so a `_pb2` module must stay light: it imports only protobuf
    and `joshua_core.config_pb2`. See docs/configuration.md for the field numbers.

    `settings="module:function"` (optional) names the function that turns the option into the plugin's
    typed settings, `function(options, config) -> settings`: `options` is the option's message in
    `config`, the SimulationConfig or TrainingConfig it extends, whose shared fields the settings may
    read too. It returns a frozen object, raises ConfigError (one line naming the field) for a bad
    value, and is imported and called only when a mode or trainer asks its `RunContext.settings(name,
    config)`, once per config and run. Without it, the option's message is its settings.
    """


@hookspec
def joshua_register_readers(registry: Registrar) -> None:
    """Register model file readers (formats MuJoCo does not read): `registry.add(suffix, target, summary)`.

    Called by PluginHost when it is built. `suffix` is the lower-case file suffix with its dot
    (".usd"); `target` is a `joshua_core.interfaces.ModelReader` subclass or its path, imported only
    when a model with that suffix is loaded. MJCF (.xml) is MuJoCo's own and is not registered.
    """


@hookspec
def joshua_register_trajectory_readers(registry: Registrar) -> None:
    """Register trajectory sources other than JOSHUA's CSV (e.g. LeRobot datasets): `registry.add(name, target,
    summary)`.

    Called by PluginHost when it is built. `target` is a `joshua_core.interfaces.TrajectoryReader` subclass or
    its path; `joshua_core.trajectory_sources.load_trajectory` asks each registered reader whether it `accepts` a
    folder it is given. The CSV reader is built in and not registered.
    """


@hookspec
def joshua_register_policy_formats(registry: Registrar) -> None:
    """Register formats of saved policies that no JOSHUA trainer wrote (e.g. LeRobot's pretrained-policy folders):
    `registry.add(name, target, summary)`.

    Called by PluginHost when it is built. `target` is a `joshua_core.interfaces.PolicyFormat` subclass or its
    path; `joshua eval FOLDER` declares each registered format's options and, for a folder without a JOSHUA run's
    `trainer` entry, asks each format whether it `accepts` the folder.
    """


@hookspec
def joshua_register_data_folders(registry: Registrar) -> None:
    """Register folders of shipped data (robot models, presets): `registry.add(name, target, summary)`.

    Called by PluginHost when it is built. `target` is the `pathlib.Path` of a folder, or the "module:attribute"
    path of one, that holds `models/` (model files that relative paths in configs and presets resolve against),
    `presets/` (`.pbtxt` presets, by file name) or both; `name` names the folder in `joshua plugins`. The core
    ships no data: `joshua_core.resources` looks in every registered folder, and a preset two plugins ship is an
    error naming both.
    """
