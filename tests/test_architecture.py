"""The house rules hold in the source (tools/check_architecture.py), and the check finds a broken one."""

from __future__ import annotations

import importlib.util
import json
import shutil
import sys
from pathlib import Path
from types import ModuleType

REPO_ROOT = Path(__file__).resolve().parents[1]


def load_tool(name: str) -> ModuleType:
    """A script of tools/ as a module (tools/ is not a package; the scripts import each other by name)."""
    sys.path.insert(0, str(REPO_ROOT / "tools"))
    try:
        spec = importlib.util.spec_from_file_location(name, REPO_ROOT / "tools" / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    finally:
        sys.path.remove(str(REPO_ROOT / "tools"))


def test_the_source_keeps_the_house_rules() -> None:
    assert load_tool("check_architecture").findings() == []


def fake_repository(root: Path, files: dict[str, str]) -> None:
    """A core with one leaf module and a plugin distribution `joshua-demo` (a backend), plus `files`."""
    (root / "joshua_core").mkdir(parents=True)
    shutil.copy(REPO_ROOT / "joshua_core" / "providers.json", root / "joshua_core" / "providers.json")
    plugin = root / "plugins" / "joshua-demo"
    (plugin / "joshua_demo").mkdir(parents=True)
    (plugin / "pyproject.toml").write_text('[project]\nname = "joshua-demo"\n')
    sources = {
        "joshua_core/__init__.py": "",
        "joshua_core/errors.py": "",
        "plugins/joshua-demo/joshua_demo/__init__.py": "",
    }
    for name, text in {**sources, **files}.items():
        (root / name).write_text(text)


def test_a_circle_a_function_local_import_hides_is_found(tmp_path: Path) -> None:
    check = load_tool("check_architecture")
    fake_repository(
        tmp_path,
        {
            "joshua_core/a.py": "from joshua_core.b import B\n",
            "joshua_core/b.py": "def f():\n    from joshua_core.a import A\n",  # the dodge the rule forbids
            "joshua_core/c.py": "import typing\nif typing.TYPE_CHECKING:\n    from joshua_core.a import A\n",
        },
    )
    found = check.findings(tmp_path)
    assert found == ["joshua_core: import circle: joshua_core.a -> joshua_core.b"], found


def test_layering_and_discovery_rules_are_found(tmp_path: Path) -> None:
    check = load_tool("check_architecture")
    catalog = json.loads((REPO_ROOT / "joshua_core" / "providers.json").read_text())
    trainer = next(name for name, provided in catalog.items() if "trainer" in provided)
    fake_repository(
        tmp_path,
        {
            "joshua_core/cli.py": "import joshua_demo\n",
            "plugins/joshua-demo/joshua_demo/lib.py": "def f(host):\n    return host.discover()\n",
        },
    )
    trainer_package = tmp_path / "plugins" / trainer / trainer.replace("-", "_")
    trainer_package.mkdir(parents=True)
    (trainer_package.parent / "pyproject.toml").write_text(f'[project]\nname = "{trainer}"\n')
    (trainer_package / "__init__.py").write_text('__all__ = ["Public"]\n')
    (trainer_package / "inner.py").write_text("")
    backend = next(name for name, provided in catalog.items() if "backend" in provided)
    backend_package = tmp_path / "plugins" / backend / backend.replace("-", "_")
    backend_package.mkdir(parents=True)
    (backend_package.parent / "pyproject.toml").write_text(f'[project]\nname = "{backend}"\n')
    (backend_package / "__init__.py").write_text(f"from {trainer_package.name} import Public\n")
    (backend_package / "deep.py").write_text(f"from {trainer_package.name}.inner import x\n")
    found = "\n".join(check.findings(tmp_path))
    assert "joshua_core/cli.py:1: the core imports plugin module joshua_demo" in found
    assert "lib.py:2: PluginHost.discover() in library code (f)" in found
    assert f"__init__.py:1: backend {backend} imports trainer {trainer_package.name}" in found
    assert f"deep.py:1: imports {trainer_package.name}.inner; import from {trainer_package.name} (its __all__)" in found


def plugin(root: Path, distribution: str, files: dict[str, str]) -> str:
    """A plugin distribution in a fake repository, its package's modules by name; returns the package name."""
    package = root / "plugins" / distribution / distribution.replace("-", "_")
    package.mkdir(parents=True)
    (package.parent / "pyproject.toml").write_text(f'[project]\nname = "{distribution}"\n')
    for name, text in {"__init__.py": "", **files}.items():
        (package / name).write_text(text)
    return package.name


def test_arrows_one_way_rules_are_found(tmp_path: Path) -> None:
    """A trainer importing a backend, a mode constructing a backend's engine, a plugin naming another's task."""
    check = load_tool("check_architecture")
    catalog = json.loads((REPO_ROOT / "joshua_core" / "providers.json").read_text())
    trainer = next(name for name, provided in catalog.items() if "trainer" in provided)
    backend, task = next(
        (name, provided["task"][0]) for name, provided in catalog.items() if {"task", "backend"} <= set(provided)
    )
    mode = next(name for name, provided in catalog.items() if "mode" in provided and "backend" not in provided)
    fake_repository(tmp_path, {})
    backend_package = plugin(
        tmp_path, backend, {"__init__.py": '__all__ = ["DemoEngine", "make"]\n', "tasks.py": f'NAME = "{task}"\n'}
    )
    plugin(tmp_path, trainer, {"api.py": f"from {backend_package} import make\n"})
    plugin(tmp_path, mode, {"run.py": f'from {backend_package} import DemoEngine\nTASK = "{task}"\n'})
    found = check.findings(tmp_path)
    assert len(found) == 3, found  # the backend may name its own task
    lines = "\n".join(found)
    assert f"api.py:1: trainer {trainer} imports backend {backend_package}; ask the run for environments" in lines
    assert f"run.py:1: {mode} imports {backend_package}.DemoEngine, a backend's class" in lines
    assert f"run.py:2: names {backend}'s task '{task}'" in lines


def test_a_compile_cache_in_the_core_is_found(tmp_path: Path) -> None:
    """The core may trace with JAX, but Warp and the compile caches' settings are joshua-jax's."""
    check = load_tool("check_architecture")
    fake_repository(
        tmp_path,
        {
            "joshua_core/random.py": "def key():\n    import jax\n    return jax.random.key(0)\n",
            "joshua_core/cache.py": (
                "import os\nimport jax\n\ndef keep(folder):\n    import warp\n"
                '    jax.config.update("jax_compilation_cache_dir", folder)\n'
                "    warp.config.kernel_cache_dir = folder\n"
                '    return os.environ.get("WARP_CACHE_PATH")\n'
            ),
        },
    )
    found = check.findings(tmp_path)
    assert [line.split(": ")[0] for line in found] == [f"joshua_core/cache.py:{line}" for line in (5, 6, 7, 8)], found
    assert "the core imports warp" in found[0] and "compile-cache setting jax_compilation_cache_dir" in found[1]


def test_a_task_the_core_defines_is_found(tmp_path: Path) -> None:
    """A TaskSpec constructed in the core, or a task hook implemented there, is a finding; in a plugin neither is."""
    check = load_tool("check_architecture")
    task = 'TaskSpec(name="arm_reach", model_path="arm/scene.xml")\n'
    hook = "@hookimpl\ndef joshua_register_tasks(registry):\n    pass\n"
    fake_repository(
        tmp_path,
        {
            "joshua_core/tasks.py": f"from joshua_core.spec import TaskSpec\nARM = {task}",
            "joshua_core/own_plugin.py": f"from joshua_core.hooks import hookimpl\n{hook}",
            "joshua_core/hooks.py": "@hookspec\ndef joshua_register_tasks(registry):\n    pass\n",  # the spec
        },
    )
    plugin(tmp_path, "joshua-arm", {"tasks.py": f"from joshua_core import spec\nARM = spec.{task}", "plugin.py": hook})
    found = check.findings(tmp_path)
    assert len(found) == 2, found
    lines = "\n".join(found)
    assert "joshua_core/tasks.py:2: the core constructs a TaskSpec; a robot's tasks live with the plugin" in lines
    assert "joshua_core/own_plugin.py:3: the core implements joshua_register_tasks" in lines


def test_the_core_task_rule_names_the_real_class_and_hook() -> None:
    """The rule above looks for names the core defines: a rename would let it pass without looking at anything."""
    check = load_tool("check_architecture")
    spec = (REPO_ROOT / "joshua_core" / "tasks" / "spec.py").read_text(encoding="utf-8")
    hooks = (REPO_ROOT / "joshua_core" / "hookspecs.py").read_text(encoding="utf-8")
    assert f"\nclass {check.TASK_CLASS}:" in spec
    assert f"@hookspec\ndef {check.TASK_HOOK}(" in hooks


def test_the_layer_picture_is_drawn_from_the_current_imports() -> None:
    spec = importlib.util.spec_from_file_location("architecture_layers", REPO_ROOT / "docs" / "architecture_layers.py")
    layers = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(layers)
    drawn = (REPO_ROOT / "docs" / "architecture_layers.svg").read_text(encoding="utf-8")
    assert drawn == layers.render(), "out of date: run python docs/architecture_layers.py"


def test_robot_data_in_the_core_is_found(tmp_path: Path) -> None:
    """The core's wheel force-including a folder, a model or preset inside joshua_core/, the core naming the
    distribution that ships the data: each is found."""
    check = load_tool("check_architecture")
    catalog = json.loads((REPO_ROOT / "joshua_core" / "providers.json").read_text())
    shipper = next(name for name, provided in catalog.items() if "data_folder" in provided)
    fake_repository(tmp_path, {"joshua_core/resources.py": f'HOME = "{shipper.replace("-", "_")}"\n'})
    (tmp_path / "pyproject.toml").write_text(
        '[tool.hatch.build.targets.wheel.force-include]\n"models" = "joshua_core/models"\n'
    )
    (tmp_path / "joshua_core" / "presets").mkdir()
    (tmp_path / "joshua_core" / "presets" / "sim.pbtxt").write_text("")
    found = check.findings(tmp_path)
    assert [line.split(": ")[0] for line in found] == [
        "pyproject.toml",
        "joshua_core/presets",
        "joshua_core/presets/sim.pbtxt",
        "joshua_core/resources.py",
    ], found
    assert f"names {shipper}, which ships data" in found[3]
