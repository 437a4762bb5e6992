"""Plugin discovery: entry points, broken and duplicate plugins, disabling, lazy loading, errors."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path
from types import ModuleType

import joshua_sample_plugin
import pytest

from joshua_core import __version__, builtin_plugin, catalog, hookimpl
from joshua_core.config_pb2 import SimulationConfig, TrainingConfig
from joshua_core.errors import ConfigError, PluginLoadError, PluginNotFoundError, UsageError
from joshua_core.interfaces import Backend, EnvKind, EnvSpec, Mode
from joshua_core.kinds import Kind
from joshua_core.plugins import PluginHost, PluginInfo
from joshua_core.run_context import RunContext


def install_fake_distribution(site: Path, distribution: str, entry_name: str, module: str, source: str) -> None:
    """Write a real installed distribution (module + dist-info with a `joshua` entry point) into `site`."""
    site.mkdir(exist_ok=True)
    (site / f"{module}.py").write_text(textwrap.dedent(source))
    dist_info = site / f"{distribution.replace('-', '_')}-0.3.dist-info"
    dist_info.mkdir()
    (dist_info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {distribution}\nVersion: 0.3\n")
    (dist_info / "entry_points.txt").write_text(f"[joshua]\n{entry_name} = {module}\n")


BROKEN_PLUGIN = """
    raise ImportError("libfoo.so.1: cannot open shared object file")
"""

SECOND_MUJOCO_PLUGIN = """
    from joshua_core import hookimpl

    @hookimpl
    def joshua_register_backends(registry):
        registry.add("mujoco", "joshua_mujoco.engine:MuJoCoBackend", "a fork")
"""


def test_broken_plugin_is_reported_and_the_others_still_load(tmp_path: Path, run_joshua) -> None:
    site = tmp_path / "site"
    install_fake_distribution(site, "joshua-broken", "broken", "joshua_broken_plugin", BROKEN_PLUGIN)
    listing = run_joshua("plugins", env={"PYTHONPATH": str(site)})
    assert listing.returncode == 0, listing.stderr
    assert "broken  (joshua-broken 0.3) [BROKEN]" in listing.stdout
    assert "ImportError: libfoo.so.1: cannot open shared object file" in listing.stdout
    assert "backend  mujoco" in listing.stdout

    run = run_joshua(
        "--set", "simulation.mode=HEADLESS", "--set", "simulation.duration=0.2", env={"PYTHONPATH": str(site)}
    )
    assert run.returncode == 0, run.stderr
    assert "warning: plugin 'broken' (joshua-broken 0.3) is broken" in run.stderr
    assert "Traceback" not in run.stderr


def test_duplicate_names_are_rejected_naming_both_providers(tmp_path: Path, run_joshua) -> None:
    site = tmp_path / "site"
    install_fake_distribution(site, "mujoco-fork", "mujoco_fork", "mujoco_fork_plugin", SECOND_MUJOCO_PLUGIN)
    env = {"PYTHONPATH": str(site)}
    listing = run_joshua("plugins", env=env)
    assert (
        "conflict: backend 'mujoco' is registered by both 'mujoco' (joshua-mujoco) and 'mujoco_fork' (mujoco-fork)"
        in (listing.stdout)
    )
    run = run_joshua(env=env)
    assert run.returncode == 2
    assert "registered by both" in run.stderr and "JOSHUA_DISABLE_PLUGINS=mujoco_fork" in run.stderr
    fixed = run_joshua(
        "--set",
        "simulation.mode=HEADLESS",
        "--set",
        "simulation.duration=0.2",
        env={**env, "JOSHUA_DISABLE_PLUGINS": "mujoco-fork"},
    )
    assert fixed.returncode == 0, fixed.stderr


OLD_SIGNATURE_BACKEND = """
    from joshua_core import hookimpl
    from joshua_core.interfaces import Backend
    from joshua_mujoco import MuJoCoEngine

    class OldBackend(Backend):
        def create_engine(self, model_path, *, render_width=640, render_height=480):  # before it took the plugins
            return MuJoCoEngine(model_path, render_width=render_width, render_height=render_height)

    @hookimpl
    def joshua_register_backends(registry):
        registry.add("mujoco_old", OldBackend, "written for an older joshua-core")
"""


def test_a_backend_of_an_older_interface_is_one_line_naming_plugin_method_and_change(
    tmp_path: Path, run_joshua
) -> None:
    """A third-party backend whose create_engine predates the `plugins` argument is refused before it is called,
    in one line, rather than failing inside the core with a TypeError traceback."""
    site = tmp_path / "site"
    install_fake_distribution(site, "joshua-old", "old", "joshua_old_plugin", OLD_SIGNATURE_BACKEND)
    run = run_joshua(
        "--set", "simulation.mode=HEADLESS", "--set", "simulation.backend=mujoco_old", env={"PYTHONPATH": str(site)}
    )  # fmt: skip
    assert run.returncode == 1 and run.stderr.count("\n") == 1, run.stderr
    assert run.stderr == (
        "joshua: error: backend 'mujoco_old' from plugin 'old' (joshua-old): create_engine(self, model_path, *, "
        "render_width=640, render_height=480) does not fit joshua-core "
        f"{__version__}'s Backend.create_engine(self, model_path, plugins, *, render_width=640, render_height=480): it "
        "lacks 'plugins'; the plugin was written for another joshua-core: update it\n"
    )


def test_disabled_plugin_is_listed_and_named_when_needed(run_joshua) -> None:
    env = {"JOSHUA_DISABLE_PLUGINS": "mujoco"}
    assert "[disabled]" in run_joshua("plugins", env=env).stdout
    run = run_joshua(env=env)
    assert run.returncode == 2
    assert "no backend named 'mujoco' is installed. It comes from joshua-mujoco, which is disabled" in run.stderr


def test_the_provider_catalog_is_what_the_first_party_plugins_register() -> None:
    """providers.json (the "pip install" hints) equals what each first-party plugin's hooks register, both ways."""
    tools = str(Path(__file__).resolve().parents[1] / "tools")
    sys.path.insert(0, tools)
    try:
        import provider_catalog
    finally:
        sys.path.remove(tools)
    shipped = json.loads(catalog.CATALOG_FILE.read_text(encoding="utf-8"))
    assert shipped == provider_catalog.build(), "out of date: run python tools/provider_catalog.py"


@pytest.mark.parametrize("command", ["sysid", "usd", "lerobot-export", "mirror-replay", "deploy", "export"])
def test_a_command_of_a_disabled_plugin_names_its_distribution(run_joshua, command: str) -> None:
    distribution = catalog.provider(Kind.COMMAND, command)
    run = run_joshua(command, env={"JOSHUA_DISABLE_PLUGINS": distribution})
    assert run.returncode == 2, run.stderr
    assert run.stderr.startswith(f"joshua: error: no command named '{command}' is installed. It comes from ")
    assert f"{distribution}, which is disabled by JOSHUA_DISABLE_PLUGINS" in run.stderr
    assert run.stderr.count("\n") == 1, run.stderr  # one line


@pytest.mark.parametrize("command", ["sysid", "usd", "lerobot-export", "mirror-replay", "deploy", "export"])
def test_a_command_of_an_absent_plugin_says_what_to_install(command: str) -> None:
    host = PluginHost([(PluginInfo("core", "joshua-core", "0", "core"), builtin_plugin)])  # nothing else installed
    distribution = catalog.provider(Kind.COMMAND, command)
    with pytest.raises(PluginNotFoundError, match=f"Install the plugin that provides it: pip install {distribution} "):
        host.command(command)


def test_entry_point_modules_import_no_physics_or_ml_stack() -> None:
    probe = (
        "import sys; from joshua_core.kinds import Kind; from joshua_core.plugins import PluginHost; "
        "host = PluginHost.discover(); "
        "assert host.names(Kind.BACKEND), 'no backend'; "
        "print(sorted(m for m in ('mujoco', 'jax', 'torch', 'pxr', 'rclpy', 'cv2') if m in sys.modules))"
    )
    result = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "[]"


class GoodMode(Mode):
    def run(self, config, context) -> None:
        return None


def host_of(*plugins: tuple[str, object]) -> PluginHost:
    return PluginHost((PluginInfo(name, f"dist-{name}", "1.0", name), plugin) for name, plugin in plugins)


def plugin_module(**hooks: object) -> ModuleType:
    """An in-memory plugin module whose attributes are the given hook implementations."""
    module = ModuleType("test_plugin")
    for hook_name, function in hooks.items():
        setattr(module, hook_name, hookimpl(function))
    return module


def plugin_registering(kind: str, name: str, target: object) -> ModuleType:
    def register(registry) -> None:
        registry.add(name, target, "test component")

    return plugin_module(**{f"joshua_register_{kind}s": register})


def test_component_is_created_from_an_object_or_a_lazy_path() -> None:
    host = host_of(
        ("direct", plugin_registering("mode", "GOOD", GoodMode)),
        ("lazy", plugin_registering("backend", "mujoco", "joshua_mujoco.engine:MuJoCoBackend")),
    )
    assert isinstance(host.mode("GOOD"), GoodMode)
    assert isinstance(host.backend("mujoco"), Backend)
    assert host.names(Kind.MODE) == ["GOOD"]


def test_unknown_name_lists_installed_ones_and_the_providing_distribution() -> None:
    host = host_of(("direct", plugin_registering("mode", "GOOD", GoodMode)))
    with pytest.raises(PluginNotFoundError, match=r"(?s)pip install joshua-modes.*Installed modes: GOOD"):
        host.mode("OFFSCREEN")
    with pytest.raises(PluginNotFoundError, match="Did you mean: GOOD"):
        host.mode("GOOF")


def test_hook_that_raises_marks_only_its_plugin_broken() -> None:
    def explode(registry) -> None:
        registry.add("HALF", GoodMode)
        raise RuntimeError("config file missing")

    host = host_of(
        ("bad", plugin_module(joshua_register_modes=explode)),
        ("good", plugin_registering("mode", "GOOD", GoodMode)),
    )
    assert host.names(Kind.MODE) == ["GOOD"]
    assert host.problems == [
        "plugin 'bad' (dist-bad 1.0) is broken: joshua_register_modes raised RuntimeError: config file missing"
    ]


def test_hookimpl_with_a_wrong_signature_is_a_broken_plugin() -> None:
    def wrong(registry, extra) -> None:
        return None

    host = host_of(("bad", plugin_module(joshua_register_modes=wrong)))
    assert "bad" in host.problems[0] and "extra" in host.problems[0]


def test_lazy_target_with_a_missing_dependency_names_plugin_and_module(tmp_path: Path, monkeypatch) -> None:
    (tmp_path / "heavy_trainer_module.py").write_text("import jax_that_is_not_installed\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    host = host_of(("heavy", plugin_registering("trainer", "ppo", "heavy_trainer_module:PPO")))
    with pytest.raises(
        PluginLoadError, match=r"plugin 'heavy' \(dist-heavy\).*missing module 'jax_that_is_not_installed'"
    ):
        host.component(Kind.TRAINER, "ppo").load()


def test_lazy_target_naming_a_module_that_does_not_exist() -> None:
    host = host_of(("typo", plugin_registering("trainer", "ppo", "joshua_no_such_module.trainer:PPO")))
    with pytest.raises(PluginLoadError, match="names module 'joshua_no_such_module.trainer', which does not exist"):
        host.component(Kind.TRAINER, "ppo").load()


def test_lazy_target_may_name_a_nested_attribute() -> None:
    host = host_of(("nested", plugin_registering("mode", "NESTED", "joshua_core.plugins:Kind.MODE")))
    assert host.component(Kind.MODE, "NESTED").load() is Kind.MODE


def test_misspelled_hook_name_marks_the_plugin_broken() -> None:
    def register(registry) -> None:
        registry.add("GOOD", GoodMode)

    host = host_of(("typo", plugin_module(joshua_register_mode=register)))
    assert "joshua_register_mode" in host.problems[0] and host.names(Kind.MODE) == []


def test_broken_plugin_keeps_nothing_it_registered() -> None:
    def modes(registry) -> None:
        registry.add("EARLY", GoodMode)

    def trainers(registry) -> None:
        raise RuntimeError("late failure")

    host = host_of(("bad", plugin_module(joshua_register_modes=modes, joshua_register_trainers=trainers)))
    assert host.names(Kind.MODE) == [] and host.plugins[0].components == []


def test_same_name_twice_from_one_plugin_is_its_own_error() -> None:
    def modes(registry) -> None:
        registry.add("TWICE", GoodMode)
        registry.add("TWICE", GoodMode)

    host = host_of(("bad", plugin_module(joshua_register_modes=modes)))
    assert "registered twice by the same plugin" in host.problems[0]
    assert host.conflicts == []


def test_disable_list_matches_names_with_dashes_or_underscores() -> None:
    host = PluginHost.discover(disabled=["JOSHUA_MUJOCO"])
    assert [info.disabled for info in host.plugins if info.name == "mujoco"] == [True]


def test_target_of_the_wrong_type_is_rejected() -> None:
    host = host_of(("odd", plugin_registering("mode", "ODD", "joshua_core.config:load_file")))
    with pytest.raises(PluginLoadError, match="not a subclass of joshua_core.interfaces.Mode"):
        host.mode("ODD")


def test_conflict_makes_the_name_unusable() -> None:
    host = host_of(
        ("one", plugin_registering("mode", "GOOD", GoodMode)),
        ("two", plugin_registering("mode", "GOOD", GoodMode)),
    )
    with pytest.raises(UsageError, match="'one' \\(dist-one\\) and 'two' \\(dist-two\\)"):
        host.mode("GOOD")


def test_registration_rejects_malformed_targets() -> None:
    host = host_of(("bad", plugin_registering("mode", "X", "no_colon_here")))
    assert "module:attribute" in host.problems[0]


GREETING_PLUGIN = """
    from joshua_core import hookimpl
    from joshua_core.interfaces import Command

    class Greet(Command):
        def add_arguments(self, parser):
            parser.add_argument("who")
            parser.add_argument("--times", type=int, default=1)

        def run(self, args, plugins):
            print(" ".join([f"hello {args.who}"] * args.times))
            return 3

    @hookimpl
    def joshua_register_commands(registry):
        registry.add("greet", Greet, "say hello")
"""


def test_plugin_subcommand_gets_its_own_arguments_and_exit_status(tmp_path: Path, run_joshua) -> None:
    site = tmp_path / "site"
    install_fake_distribution(site, "joshua-greet", "greet", "joshua_greet_plugin", GREETING_PLUGIN)
    env = {"PYTHONPATH": str(site)}
    assert "greet" in run_joshua("--help", env=env).stdout
    result = run_joshua("greet", "world", "--times", "2", env=env)
    assert result.returncode == 3, result.stderr
    assert result.stdout.strip() == "hello world hello world"
    usage = run_joshua("greet", "--help", env=env)
    assert usage.returncode == 0 and "usage: joshua greet" in usage.stdout and "--times" in usage.stdout
    wrong = run_joshua("presets", "--times", "2", env=env)
    assert wrong.returncode == 2 and "unrecognized arguments: --times 2" in wrong.stderr


def test_plugins_lists_the_options_each_plugin_registers(run_joshua) -> None:
    listing = run_joshua("plugins").stdout
    for name, distribution in (("offscreen", "modes"), ("replay", "modes"), ("mirror", "mirror"), ("ppo", "ppo")):
        block = re.split(r"\n(?=\S)", listing.split(f"{distribution}  (joshua-{distribution} ")[1])[0]
        assert f"    option   {name:<14} " in block, block


def test_options_are_loaded_from_their_registered_extensions() -> None:
    host = PluginHost.discover()
    options = host.options()
    assert {"offscreen", "replay", "viewer", "mirror"} <= set(options.names(SimulationConfig.DESCRIPTOR))
    assert {"ppo", "sb3"} <= set(options.names(TrainingConfig.DESCRIPTOR))
    assert options.find(SimulationConfig.DESCRIPTOR, "offscreen").full_name == "joshua_modes.offscreen"
    assert host.options() is options  # imported once per host


@pytest.mark.parametrize(
    ("target", "problem"),
    [
        ("joshua_core.config_pb2:SimulationConfig", "not a protobuf extension named 'odd'"),
        ("joshua_modes.options_pb2:offscreen", "not a protobuf extension named 'odd'"),  # registered under another name
        ("joshua_no_such_module.options_pb2:odd", "names module 'joshua_no_such_module.options_pb2'"),
    ],
)
def test_an_option_that_is_not_an_extension_of_its_name_breaks_only_its_plugin(target: str, problem: str) -> None:
    host = host_of(
        ("odd", plugin_registering("option", "odd", target)), ("good", plugin_registering("mode", "GOOD", GoodMode))
    )
    options = host.options()  # the other plugins' options and components stay usable
    assert "odd" not in options.names(SimulationConfig.DESCRIPTOR)
    assert isinstance(host.mode("GOOD"), GoodMode)
    (line,) = host.problems
    assert re.search(rf"plugin 'odd' \(dist-odd .*\) is broken: option 'odd' .*{re.escape(problem)}", line), line


BROKEN_OPTIONS_PLUGIN = """
    from joshua_core import hookimpl

    @hookimpl
    def joshua_register_modes(registry):
        registry.add("ODD", "joshua_odd_plugin:nothing", "a mode of a plugin with broken options")

    @hookimpl
    def joshua_register_options(registry):
        registry.add("odd", "joshua_core.config_pb2:SimulationConfig", "not an extension")
"""


def test_a_plugin_with_broken_options_breaks_only_itself_on_the_command_line(tmp_path: Path, run_joshua) -> None:
    site = tmp_path / "site"
    install_fake_distribution(site, "joshua-odd", "odd", "joshua_odd_plugin", BROKEN_OPTIONS_PLUGIN)
    env = {"PYTHONPATH": os.pathsep.join(filter(None, [str(site), os.environ.get("PYTHONPATH")]))}
    # the embedded default, another plugin's mode
    run = run_joshua("--set", "simulation.mode=HEADLESS", "--set", "simulation.duration=0.1", env=env)
    assert run.returncode == 0, run.stderr
    assert "joshua: warning: plugin 'odd' (joshua-odd 0.3) is broken: option 'odd'" in run.stderr
    odd = run_joshua("--set", "simulation.mode=ODD", env=env)
    assert odd.returncode == 2 and "Traceback" not in odd.stderr
    assert "plugin 'odd' (joshua-odd 0.3) is broken: option 'odd'" in odd.stderr
    assert "joshua: error: no mode named 'ODD' is installed." in odd.stderr  # its mode went with it


SAMPLE_CONFIG = """\
operation_mode: SIMULATION
simulation {
  mode: SAMPLE
  model_path: "so_arm100/scene.xml"
  sample { level: 2 sizes: [3, 4] }
}
"""


def test_a_third_party_plugin_adds_a_mode_and_its_options(tmp_path: Path, run_joshua) -> None:
    """The sample plugin, installed as a distribution, adds SAMPLE and `sample` without touching the core."""
    site = tmp_path / "site"
    source = (Path(__file__).parent / "joshua_sample_plugin.py").read_text()
    install_fake_distribution(site, "joshua-sample", "sample", "joshua_sample_plugin", source)
    env = {"PYTHONPATH": os.pathsep.join(filter(None, [str(site), os.environ.get("PYTHONPATH")]))}
    listing = run_joshua("plugins", env=env).stdout
    assert "    mode     SAMPLE " in listing and "    option   sample " in listing
    config = tmp_path / "sample.pbtxt"
    config.write_text(SAMPLE_CONFIG)
    run = run_joshua("--config", str(config), "--set", "simulation.sample.label=set", env=env)
    assert run.returncode == 0, run.stderr
    written = json.loads((tmp_path / "joshua_output" / "sample.json").read_text())
    assert written == {"level": 2, "sizes": [3, 4], "label": "set"}
    printed = run_joshua("--config", str(config), "--print-config", env=env)
    assert "  mode: SAMPLE\n" in printed.stdout and "  sample {\n    level: 2\n" in printed.stdout
    config.write_text(SAMPLE_CONFIG.replace("level: 2", "levle: 2"))
    error = run_joshua("--config", str(config), env=env)
    assert error.returncode == 2 and f"{config}:5:12: " in error.stderr and "Did you mean: level" in error.stderr
    missing = run_joshua("--config", str(config))  # not installed: the mode is what to install, not a field error
    assert missing.returncode == 2 and "no mode named 'SAMPLE' is installed" in missing.stderr
    assert "levle" not in missing.stderr and "Traceback" not in missing.stderr


def test_a_run_resolves_the_settings_of_an_option_once(tmp_path: Path) -> None:
    """A settings function gets the option and the config it extends, once per run and config; an option registered
    without one is its own settings, its message."""
    calls: list[int] = []

    def settings(options, config) -> tuple[int, float]:
        calls.append(options.level)
        return options.level, config.duration

    def register(registry) -> None:
        registry.add("sample", "joshua_sample_plugin:sample", "with settings", settings=settings)

    context = RunContext(host_of(("settled", plugin_module(joshua_register_options=register))), tmp_path)
    config = SimulationConfig(duration=2.0)
    config.Extensions[joshua_sample_plugin.sample].level = 3
    first = context.settings("sample", config)
    assert first == (3, 2.0) and all(context.settings("sample", config) is first for _ in range(3))
    assert calls == [3]
    config.Extensions[joshua_sample_plugin.sample].level = 4  # another config: its own settings
    assert context.settings("sample", config) == (4, 2.0) and calls == [3, 4]
    assert RunContext(context.plugins, tmp_path).settings("sample", config) == (4, 2.0)  # another run resolves again
    assert calls == [3, 4, 4]
    plain = RunContext(host_of(("sample", joshua_sample_plugin)), tmp_path)
    assert plain.settings("sample", config) is config.Extensions[joshua_sample_plugin.sample]
    with pytest.raises(ConfigError, match="SimulationConfig has no option 'ppo'"):
        plain.settings("ppo", config)
    host = host_of(
        ("odd", plugin_module(joshua_register_modes=lambda registry: registry.add("X", GoodMode, settings=len)))
    )
    assert "only options register settings" in host.problems[0]


SETTLED_REGISTRATION = 'registry.add("sample", "joshua_sample_plugin:sample", "SAMPLE: level, sizes, label")'
SETTLED_SETTINGS = """

from joshua_core.errors import ConfigError


def sample_settings(options, config):
    if options.level < 0:
        raise ConfigError(f"simulation.sample.level must not be negative, got {options.level}")
    return options
"""


def test_a_bad_value_a_settings_function_rejects_is_one_line_exit_2(tmp_path: Path, run_joshua) -> None:
    """The sample plugin with a settings function that its mode asks the run for."""
    source = (Path(__file__).parent / "joshua_sample_plugin.py").read_text()
    source = source.replace(
        SETTLED_REGISTRATION, SETTLED_REGISTRATION[:-1] + ', settings="joshua_sample_plugin:sample_settings")'
    ).replace("options_of(config, sample)", 'context.settings("sample", config)')
    site = tmp_path / "site"
    install_fake_distribution(site, "joshua-sample", "sample", "joshua_sample_plugin", source + SETTLED_SETTINGS)
    env = {"PYTHONPATH": os.pathsep.join(filter(None, [str(site), os.environ.get("PYTHONPATH")]))}
    config = tmp_path / "sample.pbtxt"
    config.write_text(SAMPLE_CONFIG)
    run = run_joshua("--config", str(config), env=env)
    assert run.returncode == 0, run.stderr
    assert json.loads((tmp_path / "joshua_output" / "sample.json").read_text())["level"] == 2
    bad = run_joshua("--config", str(config), "--set", "simulation.sample.level=-1", env=env)
    assert bad.returncode == 2, bad.stderr
    assert bad.stderr == "joshua: error: simulation.sample.level must not be negative, got -1\n"


def plugin_with_env_kinds(kind: str, *components: tuple[str, object, tuple[str, ...]]) -> ModuleType:
    def register(registry) -> None:
        for name, target, env_kinds in components:
            registry.add(name, target, "test component", env_kinds=env_kinds)

    return plugin_module(**{f"joshua_register_{kind}s": register})


class EnginesOnly(Backend):
    def create_engine(self, model_path, plugins, *, render_width=640, render_height=480):
        raise NotImplementedError


def test_env_kinds_are_declared_at_registration_and_checked_without_importing_anything() -> None:
    host = host_of(  # the targets do not exist: checking must not import them
        ("backends", plugin_with_env_kinds(
            "backend", ("cpu", "no_such_module:Cpu", ("numpy",)), ("gpu", "no_such_module:Gpu", ("jax",)),
            ("both", "no_such_module:Both", ("numpy", "jax")),
        )),
        ("trainers", plugin_with_env_kinds(
            "trainer", ("needs_jax", "no_such_module:T", ("jax",)), ("any", "no_such_module:A", ()),
        )),
    )  # fmt: skip
    assert host.component(Kind.BACKEND, "both").env_kinds == ("numpy", "jax")
    host.check_env_kinds("needs_jax", "gpu")
    host.check_env_kinds("any", "cpu")  # a trainer that declares nothing is not checked
    with pytest.raises(ConfigError) as caught:
        host.check_env_kinds("needs_jax", "cpu")
    assert str(caught.value) == (
        "trainer 'needs_jax' needs JAX environments, which backend 'cpu' does not provide; backends that do: both, gpu"
    )
    with pytest.raises(ConfigError, match="trainer 'any' needs NUMPY environments.*backends that do: both, cpu"):
        host.check_env_kinds("any", "gpu", needs=[EnvKind.NUMPY])
    with pytest.raises(PluginNotFoundError, match="no backend named 'usd'"):
        host.check_env_kinds("needs_jax", "usd")


def test_env_kinds_must_be_known_and_only_backends_and_trainers_declare_them() -> None:
    host = host_of(
        ("typo", plugin_with_env_kinds("backend", ("cpu", EnginesOnly, ("numpyy",)))),
        ("mode", plugin_with_env_kinds("mode", ("GOOD", GoodMode, ("numpy",)))),
    )
    assert "unknown env_kinds ['numpyy']; known: numpy, jax" in host.problems[0]
    assert "only backends and trainers declare env_kinds" in host.problems[1]


def test_environments_come_from_the_backend_the_training_config_names(tmp_path: Path) -> None:
    made: list[tuple[EnvSpec, EnvKind]] = []

    class Provider(EnginesOnly):
        def create_envs(self, spec, kind, plugins):
            made.append((spec, kind))
            return "environments"

    host = host_of(
        ("provider", plugin_with_env_kinds("backend", ("provider", Provider, ("numpy",)))),
        ("plain", plugin_with_env_kinds("backend", ("plain", EnginesOnly, ()))),
    )
    context = RunContext(host, tmp_path)
    training = TrainingConfig(trainer="mine", backend="provider", task="t", num_envs=3, seed=5, model_path="/m.xml")
    assert context.create_envs(training, EnvKind.NUMPY, num_envs=8) == "environments"
    # the backend gets the config too, where it reads its own options (an extension of TrainingConfig)
    assert made == [(EnvSpec("t", 8, seed=5, model_path=Path("/m.xml"), training=training), EnvKind.NUMPY)]
    with pytest.raises(ConfigError, match="trainer 'mine' needs JAX environments, which backend 'provider' does not"):
        context.create_envs(training, EnvKind.JAX)
    training.backend = "plain"
    with pytest.raises(ConfigError, match="backend 'plain' does not provide; backends that do: provider$"):
        context.create_envs(training, EnvKind.NUMPY)
    with pytest.raises(ConfigError, match="backend EnginesOnly provides no NUMPY environments"):
        EnginesOnly().create_envs(EnvSpec("t", 1), EnvKind.NUMPY, host)
    with pytest.raises(ConfigError, match="^num_envs must be at least 1, got 0$"):
        EnvSpec("t", 0)
    with pytest.raises(ConfigError, match="training.task is empty"):
        EnvSpec.from_training(TrainingConfig(num_envs=1))


def test_a_trainer_on_a_backend_without_its_environments_is_a_config_error_before_any_import(run_joshua) -> None:
    listing = run_joshua("plugins")
    assert "[provides numpy envs]" in listing.stdout and "[provides jax envs]" in listing.stdout
    assert "[needs numpy envs]" in listing.stdout and "[needs jax envs]" in listing.stdout
    run = run_joshua("--preset", "so_arm100_reach_sb3", "--set", "training.backend=mjx")
    assert run.returncode == 2, run.stderr
    assert run.stderr.strip().splitlines()[-1] == (
        "joshua: error: trainer 'sb3' needs NUMPY environments, which backend 'mjx' does not provide; "
        "backends that do: mujoco, usd"
    )
