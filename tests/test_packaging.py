"""Installed wheels work outside the repository: generated code ships inside, and the robot models and presets ship
inside joshua-tasks' wheel (its data folder), none in the core's."""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_wheels_work_from_any_directory(tmp_path: Path) -> None:
    wheels, site, elsewhere = tmp_path / "wheels", tmp_path / "site", tmp_path / "elsewhere"
    elsewhere.mkdir()
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    plugins = sorted(path.parent for path in (REPO_ROOT / "plugins").glob("*/pyproject.toml"))
    sources = [str(REPO_ROOT), *map(str, plugins)]
    subprocess.run([*pip, "wheel", "--no-deps", "--no-build-isolation", "-w", str(wheels), *sources], check=True)
    subprocess.run([*pip, "install", "--no-deps", "--target", str(site), *map(str, wheels.glob("*.whl"))], check=True)
    core_files = zipfile.ZipFile(next(wheels.glob("joshua_core-*.whl"))).namelist()
    tasks_files = zipfile.ZipFile(next(wheels.glob("joshua_tasks-*.whl"))).namelist()
    assert not [name for name in core_files if name.endswith((".xml", ".pbtxt", ".usd", ".stl", ".onnx", ".csv"))]
    shipped = {f"joshua_tasks/{path.relative_to(REPO_ROOT)}" for path in REPO_ROOT.glob("presets/*.pbtxt")}
    shipped |= {f"joshua_tasks/{path.relative_to(REPO_ROOT)}" for path in REPO_ROOT.glob("models/*/*.xml")}
    assert shipped <= set(tasks_files), sorted(shipped - set(tasks_files))
    env = {**os.environ, "PYTHONPATH": str(site)}

    def joshua(*args: str) -> subprocess.CompletedProcess[str]:
        command = [sys.executable, "-m", "joshua_core.cli", *args]
        return subprocess.run(command, cwd=elsewhere, env=env, capture_output=True, text=True, timeout=120)

    located = subprocess.run(
        [
            sys.executable,
            "-c",
            "import joshua_core, joshua_mujoco, joshua_render; "
            "print(joshua_core.__file__, joshua_mujoco.__file__, joshua_render.__file__)",
        ],
        cwd=elsewhere,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    assert all(path.startswith(str(site)) for path in located.stdout.split())
    assert len(joshua("presets").stdout.splitlines()) == len(list((REPO_ROOT / "presets").glob("*.pbtxt")))
    printed = joshua("--preset", "sim_passive", "--print-config")
    assert printed.returncode == 0, printed.stderr
    assert f'model_path: "{site}/joshua_tasks/models/so_arm100/scene.xml"' in printed.stdout
    assert f'trajectory_path: "{site}/joshua_tasks/models/trajectories/so_arm100_example.csv"' in printed.stdout
    engine = (
        "from joshua_mujoco import MuJoCoEngine; print(MuJoCoEngine(model_path='models/so_arm100/scene.xml').model.nq)"
    )
    assert subprocess.run([sys.executable, "-c", engine], cwd=elsewhere, env=env, check=True).returncode == 0
    tuned = joshua("--preset", "ant_train_mjx_tuned", "--print-config")  # the plugins' options modules ship too
    assert tuned.returncode == 0 and "\n  ppo {\n" in tuned.stdout, tuned.stderr
    run = joshua("--set", "simulation.mode=HEADLESS", "--set", "simulation.duration=0.2")
    assert run.returncode == 0, run.stderr
    assert (elsewhere / "joshua_output" / "headless_summary.json").is_file()
    listing = joshua("plugins").stdout
    for plugin in plugins:
        project = tomllib.loads((plugin / "pyproject.toml").read_text())["project"]
        registers = "joshua" in project.get("entry-points", {})  # joshua-render is a library: it registers nothing
        assert (f"({plugin.name} 0.1.0)  " in listing) == registers, listing  # each plugin's wheel registers its own
    assert "BROKEN" not in listing and "conflict" not in listing
    without = {**env, "JOSHUA_DISABLE_PLUGINS": "tasks"}  # the core alone ships no model and no preset
    bare = subprocess.run(
        [sys.executable, "-m", "joshua_core.cli"], cwd=elsewhere, env=without, capture_output=True, text=True
    )
    assert (
        bare.returncode == 2
        and "no installed plugin ships robot models; install one that does: pip install joshua-tasks" in bare.stderr
    ), bare.stderr
    unknown = subprocess.run(
        [sys.executable, "-m", "joshua_core.cli", "--preset", "sim_passive"],
        cwd=elsewhere,
        env=without,
        capture_output=True,
        text=True,
    )
    assert unknown.returncode == 2 and "unknown preset 'sim_passive'" in unknown.stderr, unknown.stderr
