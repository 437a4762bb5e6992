"""joshua-tasks registers the robot tasks under the names they always had and the data folder of the robot models
and presets, and without it the core names the distribution to install."""

from __future__ import annotations

from pathlib import Path

import pytest

import joshua_tasks.plugin
from joshua_core import builtin_plugin
from joshua_core.errors import PluginNotFoundError
from joshua_core.kinds import Kind
from joshua_core.plugins import PluginHost, PluginInfo
from joshua_core.resources import MODELS, PRESETS, data_folders
from joshua_tasks import TASKS

NAMES = {
    "ant_locomotion",
    "trileg_locomotion",
    "so_arm100_reach",
    "so_arm100_pick_place",
    "so101_reach",
    "so101_pick_place",
}


REPO_ROOT = Path(__file__).resolve().parents[3]


def tasks_host() -> PluginHost:
    """The core and joshua-tasks, nothing else installed."""
    return PluginHost(
        [
            (PluginInfo("core", "joshua-core", "0", "core"), builtin_plugin),
            (PluginInfo("tasks", "joshua-tasks", "0", "joshua_tasks.plugin"), joshua_tasks.plugin),
        ]
    )


def test_the_plugin_registers_every_task_by_its_name() -> None:
    host = tasks_host()
    assert set(TASKS) == NAMES == set(host.names(Kind.TASK))
    assert all(host.component(Kind.TASK, name).target is spec for name, spec in TASKS.items())


@pytest.mark.parametrize("name", sorted(NAMES))
def test_without_the_plugin_a_task_names_the_distribution_to_install(name: str) -> None:
    host = PluginHost([(PluginInfo("core", "joshua-core", "0", "core"), builtin_plugin)])  # the core registers none
    with pytest.raises(PluginNotFoundError) as error:
        host.component(Kind.TASK, name)
    message = str(error.value)
    assert message.startswith(f"no task named '{name}' is installed. Install the plugin that provides it: ")
    assert "pip install joshua-tasks (from a source checkout: pip install -e plugins/joshua-tasks)" in message
    assert "\n" not in message


def test_the_plugin_ships_the_repositorys_models_and_presets_from_a_checkout() -> None:
    """In a source checkout the data folder is the repository root, whose models/ and presets/ users' paths name;
    tests/test_packaging.py checks the wheel's copy."""
    (folder,) = data_folders(tasks_host())
    assert folder.path == REPO_ROOT
    assert (folder.path / MODELS / "so_arm100" / "scene.xml").is_file()
    assert any((folder.path / PRESETS).glob("*.pbtxt"))
