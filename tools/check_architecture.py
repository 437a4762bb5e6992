"""Check JOSHUA's house rules from the real imports of its source (run from anywhere; exit 1 on a finding).

    python tools/check_architecture.py

- no import circle among the modules of the core or of one plugin package, nor between distributions
  (imports inside functions count: a function-local import does not open a circle; `if TYPE_CHECKING:` ones
  do not, they never run);
- the core imports no plugin;
- the core imports no Warp and names no compile-cache setting of JAX or Warp (COMPILE_CACHE_SETTINGS): the caches
  are joshua-jax's, and the core only declares the switch that turns them off (`joshua_core.outputs`). The core
  may import JAX itself: tasks are traced in `jax.jit` (`joshua_core.tasks.context.JaxRandom`);
- a plugin imports from another only the names that one lists in its `__init__.py` `__all__`;
- a backend distribution never imports a trainer distribution, and a trainer distribution never imports a backend
  one: trainers ask the run for environments (which is which: what each registers, `joshua_core/providers.json`);
- a distribution that provides no backend imports no backend's engine or backend class (a name ending in `Engine`
  or `Backend`): modes and commands get their engine from the backend the run names (`RunContext.create_engine`,
  `PluginHost.backend`);
- no source names, as a string, a task another distribution registers: a task's other names are its own
  (`TaskSpec.aliases`), declared by the plugin that provides it;
- the core defines no task: it constructs no `TaskSpec` and implements no `joshua_register_tasks` hook. It owns the
  task machinery; a robot's tasks live with the plugin that provides the robot, or in joshua-tasks;
- the core ships no robot data: its wheel force-includes nothing, `joshua_core/` holds no model or preset file
  (CORE_DATA_SUFFIXES) and no folder of them (CORE_DATA_FOLDERS), and its source names no distribution that ships
  a data folder (`joshua_core/providers.json`); the plugins ship the models and presets, each in the data folder it
  registers, and `joshua_core.resources` finds them through the registrations;
- `PluginHost.discover()` only in the entry points listed in ENTRY_POINTS: library code takes the run's host;
- no source file over 600 lines and no function over 120, unless the file says "long because" (a reason).
  Split by meaning, never to meet these numbers.

`.ci/run` runs it before the tests, and `tests/test_architecture.py` runs it so that a new circle fails the tests.
"""

from __future__ import annotations

import ast
import json
import sys
import tomllib
from pathlib import Path
from typing import NamedTuple

sys.path.insert(0, str(Path(__file__).resolve().parent))

from import_graph import ROOT, Import, Package, all_imports, circles, distribution_graph, packages  # noqa: E402

# Where a discover() may stand, each with why: these build the host a run then passes down.
ENTRY_POINTS = {
    ("joshua_core.cli", "main"): "the `joshua` command",
    ("joshua_ppo.api", "train_mjx"): "the documented Python entry to training (docs/training-mjx.md)",
    ("joshua_modes.offscreen", "run_offscreen"): "the documented Python API for frames of a replay",
    ("joshua_modes.interactive", "run_interactive"): "the documented Python API for the viewer (joshua-modes README)",
    ("joshua_mujoco.engine", "__init__"): "MuJoCoEngine(model_path=...), the documented API, given a USD file",
    ("joshua_mujoco.envs", "__init__"): "TaskEnv: the Gymnasium entry point of gymnasium.make('joshua/...')",
    ("joshua_mujoco.envs", "register_envs"): "run on import of joshua_mujoco.envs: Gymnasium ids of all tasks",
    ("joshua_mujoco.vector", "make_vector_env"): "documented convenience (joshua-mujoco README), gymnasium.make_vec",
    ("joshua_mjx.env", "make_mjx_env"): "documented convenience (joshua-mjx README)",
    ("joshua_sb3.task_envs", "task_vec_env"): "documented convenience: any task as an SB3 VecEnv (docs/usd.md)",
    ("joshua_sb3.task_envs", "alias_env"): "`from joshua_sb3 import AntEnv`: a task's alias (docs/usd.md)",
    ("joshua_core.resources", "_installed"): "the installed plugins' data folders: users and presets name files there",
}
# JAX's and Warp's settings of their compile caches (config options, attributes, environment variables)
COMPILE_CACHE_SETTINGS = {
    "jax_compilation_cache_dir",
    "jax_enable_compilation_cache",
    "jax_persistent_cache_min_compile_time_secs",
    "jax_persistent_cache_min_entry_size_bytes",
    "JAX_COMPILATION_CACHE_DIR",
    "kernel_cache_dir",
    "cache_kernels",
    "WARP_CACHE_PATH",
}
# The class a task is written as, and the hook that registers tasks: the core constructs the one and implements
# the other nowhere (tests/test_architecture.py checks that the core still defines both under these names).
TASK_CLASS = "TaskSpec"
TASK_HOOK = "joshua_register_tasks"
# What the core's wheel would carry if robot data crept back in: the plugins' data folders hold these.
CORE_DATA_FOLDERS = ("models", "presets")
CORE_DATA_SUFFIXES = (".xml", ".pbtxt", ".usd", ".usda", ".usdc", ".usdz", ".stl", ".obj", ".onnx", ".csv")
MAX_LINES = 600
MAX_FUNCTION_LINES = 120
EXCUSE = "long because"


def module_circles(package: Package, imports: dict[str, list[Import]]) -> list[list[str]]:
    """Import circles among one package's modules (function-local imports count, type-only ones do not)."""
    modules = set(imports)
    graph: dict[str, set[str]] = {module: set() for module in modules}
    for module, items in imports.items():
        for item in items:
            if item.type_only:
                continue
            for target in (item.target, *(f"{item.target}.{name}" for name in item.names)):
                # a module's own ancestors are imported before it anyway: not an edge
                if target in modules and target != module and not module.startswith(f"{target}."):
                    graph[module].add(target)
    return circles(graph)


class Roles(NamedTuple):
    """What each first-party distribution registers, from providers.json (a NamedTuple: tests load this script
    without registering it as a module, which a dataclass would need)."""

    backends: set[str]  # distributions that register a backend
    trainers: set[str]  # distributions that register a trainer
    tasks: dict[str, str]  # task name -> the distribution that registers it
    data: set[str]  # distributions that register a data folder


def roles(root: Path) -> Roles:
    """Backend and trainer distributions, and who registers each task (joshua_core/providers.json)."""
    catalog = json.loads((root / "joshua_core" / "providers.json").read_text(encoding="utf-8"))
    return Roles(
        backends={name for name, provided in catalog.items() if "backend" in provided},
        trainers={name for name, provided in catalog.items() if "trainer" in provided},
        tasks={task: name for name, provided in catalog.items() for task in provided.get("task", ())},
        data={name for name, provided in catalog.items() if "data_folder" in provided},
    )


def layering(package: Package, other: Package, item: Import, roles: Roles) -> list[str]:
    """The role rules one import between two plugin distributions breaks, as messages without their place."""
    found: list[str] = []
    if package.distribution in roles.backends and other.distribution in roles.trainers:
        found.append(f"backend {package.distribution} imports trainer {item.target}")
    if package.distribution in roles.trainers and other.distribution in roles.backends:
        found.append(f"trainer {package.distribution} imports backend {item.target}; ask the run for environments")
    if package.distribution not in roles.backends and other.distribution in roles.backends:
        for name in item.names:
            if name.endswith(("Engine", "Backend")):
                found.append(
                    f"{package.distribution} imports {other.name}.{name}, a backend's class; get the engine from "
                    "the backend the run names (RunContext.create_engine, PluginHost.backend)"
                )
    return found


def foreign_tasks(path: Path, distribution: str, tasks: dict[str, str]) -> list[tuple[int, str, str]]:
    """(line, task, its distribution) of each string in a file that is the name of another distribution's task."""
    return [
        (node.lineno, node.value, tasks[node.value])
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
        if isinstance(node, ast.Constant)
        and isinstance(node.value, str)
        and tasks.get(node.value, distribution) != distribution
    ]


def compile_cache_settings(path: Path) -> list[tuple[int, str]]:
    """(line, setting) of each name, attribute or string in a file that is one of COMPILE_CACHE_SETTINGS."""
    found: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Attribute):
            name = node.attr
        elif isinstance(node, ast.Name):
            name = node.id
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            name = node.value
        else:
            continue
        if name in COMPILE_CACHE_SETTINGS:
            found.append((node.lineno, name))
    return sorted(found)


def compile_caches_in_core(path: Path, imports: list[Import], root: Path) -> list[str]:
    """What a core module breaks of the compile-cache rule: an import of Warp, a cache setting of JAX or Warp."""
    where = path.relative_to(root)
    found = [
        f"{where}:{item.line}: the core imports {item.target}; Warp is a plugin's (joshua-mjx, joshua-jax)"
        for item in imports
        if item.target.split(".")[0] == "warp"
    ]
    found += [
        f"{where}:{line}: the core names the compile-cache setting {name}; the caches are joshua-jax's "
        "(the core has only the switch, joshua_core.outputs.cache_enabled)"
        for line, name in compile_cache_settings(path)
    ]
    return found


def task_definitions(path: Path) -> list[tuple[int, str]]:
    """(line, what) of each task a file defines: a `TaskSpec(...)` call, or an implementation (`@hookimpl`) of the
    task registration hook."""
    found: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Call):
            called = node.func.id if isinstance(node.func, ast.Name) else getattr(node.func, "attr", None)
            if called == TASK_CLASS:
                found.append((node.lineno, f"constructs a {TASK_CLASS}"))
        elif isinstance(node, ast.FunctionDef) and node.name == TASK_HOOK:
            if any(ast.unparse(decorator).split(".")[-1] == "hookimpl" for decorator in node.decorator_list):
                found.append((node.lineno, f"implements {TASK_HOOK}"))
    return found


def core_data(root: Path, shippers: set[str]) -> list[str]:
    """What breaks the rule that the core ships no robot data: a force-include of the core's wheel, a model or
    preset file (or a folder of them) in joshua_core/, a core source naming a distribution that ships data."""
    found: list[str] = []
    pyproject = root / "pyproject.toml"
    if pyproject.is_file():
        wheel = tomllib.loads(pyproject.read_text(encoding="utf-8")).get("tool", {}).get("hatch", {}).get("build", {})
        included = wheel.get("targets", {}).get("wheel", {}).get("force-include", {})
        found += [
            f"pyproject.toml: the core's wheel force-includes {source}; ship data with a plugin (a data folder)"
            for source in included
        ]
    core = root / "joshua_core"
    for path in sorted(core.rglob("*")):
        where = path.relative_to(root)
        if path.is_dir() and path.name in CORE_DATA_FOLDERS or path.is_file() and path.suffix in CORE_DATA_SUFFIXES:
            found.append(f"{where}: robot data in the core; ship it with a plugin (a data folder it registers)")
        elif path.suffix == ".py":
            text = path.read_text(encoding="utf-8")
            for name in sorted(shippers):
                if name in text or name.replace("-", "_") in text:
                    found.append(f"{where}: names {name}, which ships data; the core finds data by registration")
    return found


def discover_calls(path: Path) -> list[tuple[int, str | None]]:
    """(line, enclosing function) of each `....discover(...)` call in a file."""
    found: list[tuple[int, str | None]] = []

    def visit(node: ast.AST, function: str | None) -> None:
        for child in ast.iter_child_nodes(node):
            inner = child.name if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef) else function
            if isinstance(child, ast.Call) and isinstance(child.func, ast.Attribute) and child.func.attr == "discover":
                found.append((child.lineno, function))
            visit(child, inner)

    visit(ast.parse(path.read_text(encoding="utf-8")), None)
    return found


def sizes(path: Path, root: Path) -> list[str]:
    text = path.read_text(encoding="utf-8")
    if EXCUSE in text:
        return []
    where = path.relative_to(root)
    lines = len(text.splitlines())
    found = [f"{where}: {lines} lines (over {MAX_LINES}, no '{EXCUSE}' reason)"] if lines > MAX_LINES else []
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            length = node.end_lineno - node.lineno + 1
            if length > MAX_FUNCTION_LINES:
                found.append(
                    f"{where}:{node.lineno}: function {node.name} is {length} lines (over {MAX_FUNCTION_LINES})"
                )
    return found


def findings(root: Path = ROOT) -> list[str]:
    """One line per broken rule."""
    known = packages(root)
    modules = all_imports(root)
    registered = roles(root)
    found: list[str] = []
    by_package: dict[str, dict[str, list[Import]]] = {}
    for module, (package, path, imports) in modules.items():
        by_package.setdefault(package.name, {})[module] = imports
        where = path.relative_to(root)
        if package.name == "joshua_core":
            found += compile_caches_in_core(path, imports, root)
        for item in imports:
            other = known.get(item.target.split(".")[0])
            if other is None or other.name == package.name or other.name == "joshua_core":
                continue
            if package.name == "joshua_core":
                found.append(f"{where}:{item.line}: the core imports plugin module {item.target}")
                continue
            found += [f"{where}:{item.line}: {message}" for message in layering(package, other, item, registered)]
            exported = other.exported()
            if item.target != other.name:
                found.append(f"{where}:{item.line}: imports {item.target}; import from {other.name} (its __all__)")
            else:
                for name in item.names or ("(the whole module)",):
                    if name not in exported:
                        found.append(f"{where}:{item.line}: {other.name}.{name} is not in {other.name}.__all__")
        if package.name == "joshua_core":
            for line, what in task_definitions(path):
                found.append(
                    f"{where}:{line}: the core {what}; a robot's tasks live with the plugin that provides the robot "
                    "or in joshua-tasks"
                )
        for line, function in discover_calls(path):
            if (module, function) not in ENTRY_POINTS:
                found.append(
                    f"{where}:{line}: PluginHost.discover() in library code ({function or 'module level'}); "
                    "take the run's host as an argument (entry points: tools/check_architecture.py ENTRY_POINTS)"
                )
        for line, task, owner in foreign_tasks(path, package.distribution, registered.tasks):
            found.append(
                f"{where}:{line}: names {owner}'s task '{task}'; let {owner} declare its other names (TaskSpec.aliases)"
            )
        found += sizes(path, root)
    for name, imports in sorted(by_package.items()):
        for circle in module_circles(known[name], imports):
            found.append(f"{known[name].folder.relative_to(root)}: import circle: {' -> '.join(circle)}")
    found += core_data(root, registered.data)
    for circle in circles(distribution_graph(root)):
        found.append(f"import circle between distributions: {' -> '.join(circle)}")
    return found


def main() -> int:
    found = findings()
    for line in found:
        print(line)
    print(f"check_architecture: {len(found)} finding(s)")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
