"""joshua-tasks registers the robot tasks under the names they always had, and without it the core names the
distribution to install."""

from __future__ import annotations

import pytest

import joshua_tasks.plugin
from joshua_core import builtin_plugin
from joshua_core.errors import PluginNotFoundError
from joshua_core.kinds import Kind
from joshua_core.plugins import PluginHost, PluginInfo
from joshua_tasks import TASKS

NAMES = {
    "ant_locomotion",
    "trileg_locomotion",
    "so_arm100_reach",
    "so_arm100_pick_place",
    "so101_reach",
    "so101_pick_place",
}


def test_the_plugin_registers_every_task_by_its_name() -> None:
    host = PluginHost(
        [
            (PluginInfo("core", "joshua-core", "0", "core"), builtin_plugin),
            (PluginInfo("tasks", "joshua-tasks", "0", "joshua_tasks.plugin"), joshua_tasks.plugin),
        ]
    )
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
