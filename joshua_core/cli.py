"""The `joshua` command line: run a preset or config, list presets and plugins."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from joshua_core import __version__, catalog
from joshua_core.config import (
    LoadedConfig,
    apply_override,
    config_text_of,
    finalize,
    load_default,
    load_file,
    load_preset,
    preset_names,
)
from joshua_core.config_pb2 import JoshuaConfig
from joshua_core.defaults import required_components, simulation_mode, simulation_output_dir, training_output_dir
from joshua_core.determinism import use_determinism
from joshua_core.errors import JoshuaError, PluginNotFoundError, UsageError
from joshua_core.interrupts import reported
from joshua_core.kinds import Kind
from joshua_core.options import LENIENT, OptionSet
from joshua_core.outputs import NO_CACHE_ENV_VAR, add_no_cache_argument, apply_no_cache, check_name, user_cache_dir
from joshua_core.plugins import DISABLE_ENV_VAR, PluginHost
from joshua_core.run_context import RunContext

STRICT_OVERRIDE = "simulation.replay.strict=true"  # what --strict means
EPISODE_OVERRIDE = "simulation.replay.episode={episode}"  # what --episode N means
DETERMINISTIC_OVERRIDE = "training.deterministic=true"  # what --deterministic means
WEB_FIELDS = {"SIMULATION": "simulation.web", "TRAINING": "training.web"}  # what --web sets, by operation_mode

EPILOG = f"""\
examples:
  joshua                                   run the embedded default: validate the example trajectory, record its replay
  joshua --preset sim_offscreen            run a shipped preset
  joshua --preset sim_passive --set simulation.trajectory_path=my_motion.csv --strict
  joshua --config my_run.pbtxt             run a text-format JoshuaConfig (it may `extends: "PRESET"`)
  joshua --preset ant_train_mjx --print-config
  joshua presets                           list the presets
  joshua plugins                           list installed plugins and what they provide
  joshua eval RUN_FOLDER                   roll out a trained policy: mean return, metrics, MP4

Relative model and trajectory paths resolve against the config file's folder, the working
directory, then the models shipped with JOSHUA. {DISABLE_ENV_VAR}=a,b skips plugins by name.
Compiled programs (JAX, Warp) are kept in {user_cache_dir()} so that a rerun starts warm;
--no-cache or {NO_CACHE_ENV_VAR}=1 turns that off.
exit status: 0 ok, 1 runtime failure, 2 usage or config error."""

# Printed after the embedded default run (`joshua` alone): what a newcomer can try next.
NEXT_STEPS = """\
next:
  joshua --preset sim_passive                the same replay in the MuJoCo viewer (with a display)
  joshua --preset so_arm100_sim_interactive  the viewer on the live arm, held at home
  joshua --preset sim_offscreen              render at 640x480; PNG, depth, segmentation on request
  joshua --preset so_arm100_reach_sb3        train a reaching policy (after ./setup.sh --all)
  joshua presets                             every shipped preset, with what it does"""


def build_parser(plugin_commands: dict[str, str] | None = None) -> argparse.ArgumentParser:
    """The top-level parser; `plugin_commands` maps subcommands that plugins registered to their help."""
    parser = argparse.ArgumentParser(
        prog="joshua",
        description="JOSHUA: robot simulation and reinforcement learning on MuJoCo.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"joshua {__version__}")
    add_config_arguments(parser, verb="run")
    parser.add_argument(
        "--strict",
        action="store_true",
        help=f"do not replay a trajectory that fails validation (same as --set {STRICT_OVERRIDE})",
    )
    parser.add_argument(
        "--episode",
        type=int,
        metavar="N",
        help="replay episode N of a trajectory that holds several, a LeRobot dataset (same as --set "
        + EPISODE_OVERRIDE.format(episode="N")
        + ")",
    )
    parser.add_argument(
        "--web",
        metavar="[HOST:]PORT",
        help="show the run in a web page at this address (HOST defaults to 127.0.0.1, this machine only): "
        "PASSIVE, INTERACTIVE, MIRROR, or a training's environments and return curve; prints the URL. "
        "Same as --set simulation.web=ADDRESS (or training.web for a training config)",
    )
    parser.add_argument(
        "--deterministic",
        action="store_true",
        help="train so that the same config and seed repeat exactly on this machine: exact on the CPU, on a GPU as "
        f"far as XLA allows (docs/determinism.md; same as --set {DETERMINISTIC_OVERRIDE})",
    )
    parser.add_argument("--print-config", action="store_true", help="print the final config and exit")
    add_no_cache_argument(parser)
    commands = parser.add_subparsers(dest="command", title="commands", metavar="COMMAND")
    commands.add_parser("presets", help="list the shipped presets with their descriptions")
    commands.add_parser("plugins", help="list installed plugins: distribution, version, what they register")
    for name, summary in (plugin_commands or {}).items():  # their own arguments are parsed by the plugin
        commands.add_parser(name, help=summary, add_help=False)
    return parser


def add_config_arguments(parser: argparse.ArgumentParser, *, verb: str) -> None:
    """Declare --preset/--config/--set, the way every command that reads a config takes it."""
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--preset", metavar="NAME", help=f"{verb} a shipped preset (see `joshua presets`)")
    source.add_argument("--config", metavar="FILE", type=Path, help=f"{verb} a text-format .pbtxt config")
    parser.add_argument(
        "--set",
        dest="overrides",
        metavar="PATH=VALUE",
        action="append",
        default=[],
        help="override one field, e.g. simulation.render_width=1280 (repeatable)",
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `joshua` script; returns the exit status."""
    host = PluginHost.discover()
    plugin_commands = {name: host.component(Kind.COMMAND, name).summary for name in host.names(Kind.COMMAND)}
    for name, distribution in catalog.provided(Kind.COMMAND).items():  # listed, so that using one says what to install
        plugin_commands.setdefault(name, f"(not installed: {distribution})")
    parser = build_parser(plugin_commands)
    args, command_argv = parser.parse_known_args(argv)
    if command_argv and args.command not in plugin_commands:
        parser.error(f"unrecognized arguments: {' '.join(command_argv)}")
    apply_no_cache(args)

    def job() -> int:
        if args.command == "presets":
            return list_presets()
        if args.command == "plugins":
            return list_plugins(host)
        if args.command in plugin_commands:
            return run_plugin_command(host, args.command, command_argv)
        return run(args, host)

    return reported(lambda: os_errors_reported(job))


def os_errors_reported(job: Callable[[], int]) -> int:
    """Run `job`; a file-system failure (name too long, no space, read-only, no permission, a NUL byte in a path)
    becomes a one-line UsageError naming the path, since it comes from where the user asked to read or write."""
    try:
        return job()
    except JoshuaError:
        raise
    except OSError as error:
        paths = " -> ".join(str(name) for name in (error.filename, error.filename2) if name is not None)
        reason = error.strerror or str(error)
        raise UsageError(f"{paths}: {reason}" if paths else reason) from None
    except ValueError as error:
        if "null byte" not in str(error) and "null character" not in str(error):
            raise
        raise UsageError(f"a path holds a NUL byte ({error}); remove it") from None


def list_presets() -> int:
    names = preset_names()
    width = max(map(len, names))
    for name in names:  # read leniently: only the description is needed, not the plugins' options
        description = load_preset(name, LENIENT).message.description
        print(f"{name:<{width}}  {description}")
    return 0


def list_plugins(host: PluginHost) -> int:
    for info in host.plugins:
        state = " [disabled]" if info.disabled else " [BROKEN]" if info.error else ""
        print(f"{info.name}  ({info.distribution} {info.version}){state}  {info.module}")
        if info.error:
            print(f"    error: {info.error}")
        for component in info.components:
            verb = "provides" if component.kind is Kind.BACKEND else "needs"
            kinds = f" [{verb} {', '.join(component.env_kinds)} envs]" if component.env_kinds else ""
            print(f"    {component.kind.value:<8} {component.name:<14} {component.summary}{kinds}")
    for conflict in host.conflicts:
        print(f"conflict: {conflict}")
    return 0


def run_plugin_command(host: PluginHost, name: str, argv: list[str]) -> int:
    """Load the plugin's subcommand, let it declare its arguments, and run it."""
    command = host.command(name)
    parser = argparse.ArgumentParser(prog=f"joshua {name}", description=host.component(Kind.COMMAND, name).summary)
    command.add_arguments(parser)
    command.add_plugin_arguments(parser, host)
    return command.run(parser.parse_args(argv), host)


def load(args: argparse.Namespace, options: OptionSet) -> LoadedConfig:
    """The config that the arguments of `add_config_arguments` describe, with the --set overrides applied.

    `options` are those the config may use: the host's (`PluginHost.options()`), or LENIENT to read only
    what the core schema holds before the plugins' options are loaded (e.g. which plugins it needs).
    """
    if args.preset:
        loaded = load_preset(args.preset, options)
    elif args.config:
        loaded = load_file(args.config, options)
    else:
        loaded = load_default(options)
    for assignment in args.overrides:
        apply_override(loaded.message, assignment, options)
    return loaded


def check_components(config: JoshuaConfig, host: PluginHost) -> None:
    """Raise PluginNotFoundError naming what to install when the config needs plugins that are missing, and
    ConfigError when its trainer needs environments its backend does not provide (from the registrations alone)."""
    needed = dict(required_components(config))
    missing = []
    for kind, name in needed.items():
        try:
            host.component(kind, name)
        except PluginNotFoundError as error:
            missing.append(str(error))
    if len(missing) == 1:
        raise PluginNotFoundError(missing[0])
    if missing:
        raise PluginNotFoundError("this config needs plugins that are not installed:\n- " + "\n- ".join(missing))
    if Kind.TRAINER in needed:  # a trainer on a backend without the environments it needs: before heavy imports
        host.check_env_kinds(needed[Kind.TRAINER], needed[Kind.BACKEND])


def run(args: argparse.Namespace, host: PluginHost) -> int:
    """Run (or print) the config: first check that its plugins are installed, reading it leniently, since
    installing them comes before any other problem (their options would be unknown); then parse it strictly."""
    options = host.options()  # first: a plugin whose options are broken is then reported like any broken plugin
    if not args.print_config:
        for problem in host.problems:
            print(f"joshua: warning: {problem}", file=sys.stderr)
    check_components(load(args, LENIENT).message, host)
    loaded = load(args, options)
    if args.strict:
        apply_override(loaded.message, STRICT_OVERRIDE, options)
    if args.episode is not None:
        if args.episode < 0:
            raise UsageError(f"--episode must be 0 or more (got {args.episode})")
        apply_override(loaded.message, EPISODE_OVERRIDE.format(episode=args.episode), options)
    if args.web is not None:
        field = WEB_FIELDS[JoshuaConfig.OperationMode.Name(loaded.message.operation_mode)]
        apply_override(loaded.message, f"{field}={args.web}", options)
    if args.deterministic:
        if loaded.message.operation_mode != JoshuaConfig.TRAINING:
            raise UsageError("--deterministic is for training configs (operation_mode: TRAINING)")
        apply_override(loaded.message, DETERMINISTIC_OVERRIDE, options)
    config = finalize(loaded)
    if args.print_config:
        print(config_text_of(config, options), end="")
        return 0
    if config.operation_mode == JoshuaConfig.SIMULATION:
        simulation = config.simulation
        folder = writable_folder(simulation_output_dir(simulation), "simulation.output_dir")
        context = RunContext(host, folder)
        host.mode(simulation_mode(simulation)).run(simulation, context)
        if not (args.preset or args.config):
            print(NEXT_STEPS)
    else:
        training = config.training
        folder = writable_folder(training_output_dir(training), "training.checkpoint_dir")
        context = RunContext(host, folder)
        use_determinism(training)  # before the trainer's import: nothing of JAX may start first
        host.trainer(training.trainer).train(training, context)
    return 0


def writable_folder(name: str, field: str) -> Path:
    """The output folder `name`, created if missing; a file there or no permission is a UsageError, before any work."""
    folder = Path(name)
    if folder.exists() and not folder.is_dir():
        raise UsageError(f"{field} '{name}' is a file, not a folder; choose another path")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise UsageError(f"{field} '{name}' cannot be created: {error.strerror}") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UsageError(f"{field} '{name}' is not writable")
    return folder


def writable_file(path: Path, option: str) -> Path:
    """An output file's path, its folder created if missing; a folder there, or a folder that cannot be created
    or written, is a UsageError before any work (the file itself is written atomically later)."""
    if path.is_dir():
        raise UsageError(f"{option} '{path}' is a folder; give a file name")
    check_name(path.name, option)
    writable_folder(str(path.parent), option)
    return path


if __name__ == "__main__":
    sys.exit(main())
