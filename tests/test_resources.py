"""Finding files named by users and presets (`resolve_data_path`), in the data folders plugins register."""

from __future__ import annotations

from pathlib import Path

import pytest

from joshua_core import builtin_plugin, hookimpl, resources
from joshua_core.config import preset_names, preset_path
from joshua_core.errors import ModelError, PluginLoadError, UsageError
from joshua_core.plugins import PluginHost, PluginInfo, Registrar
from joshua_core.resources import DataFolder, data_folders, resolve_data_path


def test_a_folder_where_a_file_is_wanted_is_named_a_folder(tmp_path: Path) -> None:
    (tmp_path / "robot").mkdir()
    with pytest.raises(ModelError, match=f"^model 'robot' is a folder \\({tmp_path / 'robot'}\\); give the path of a"):
        resolve_data_path("robot", base_dirs=(tmp_path,))
    assert resolve_data_path("robot", base_dirs=(tmp_path,), folders=True) == (tmp_path / "robot").resolve()


def test_a_missing_file_names_every_path_tried(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match=f"^trajectory file 'nowhere.csv' not found; searched:\n  {tmp_path}/nowhere"):
        resolve_data_path("nowhere.csv", base_dirs=(tmp_path,), what="trajectory")


class DataPlugin:
    """A plugin object that registers one data folder."""

    def __init__(self, name: str, target: object) -> None:
        self.name, self.target = name, target

    @hookimpl
    def joshua_register_data_folders(self, registry: Registrar) -> None:
        registry.add(self.name, self.target, "a test's data")


def host_of(*plugins: DataPlugin) -> PluginHost:
    entries = [(PluginInfo(f"p{index}", f"dist-{index}", "0", "test"), plugin) for index, plugin in enumerate(plugins)]
    return PluginHost([(PluginInfo("core", "joshua-core", "0", "core"), builtin_plugin), *entries])


def shipping(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, *folders: Path) -> None:
    """Make `folders` the installed data folders, each registered by its own plugin."""
    registered = data_folders(host_of(*(DataPlugin(folder.name, folder) for folder in folders)))
    monkeypatch.setattr(resources, "installed_folders", lambda: registered)


def test_the_core_registers_no_data_folder() -> None:
    assert data_folders(host_of()) == ()


def test_a_data_folder_that_is_no_folder_names_its_plugin(tmp_path: Path) -> None:
    host = host_of(DataPlugin("robots", tmp_path / "absent"))
    with pytest.raises(PluginLoadError, match="^data folder 'robots' from plugin 'p0' \\(dist-0\\) is PosixPath"):
        data_folders(host)


def test_models_and_presets_are_found_in_every_registered_folder(tmp_path: Path, monkeypatch) -> None:
    first, second = tmp_path / "arms", tmp_path / "legs"
    for folder, robot in ((first, "arm"), (second, "leg")):
        (folder / "models" / robot).mkdir(parents=True)
        (folder / "models" / robot / "scene.xml").write_text("<mujoco/>")
        (folder / "presets").mkdir()
        (folder / "presets" / f"{robot}_sim.pbtxt").write_text('description: "x"\n')
    monkeypatch.chdir(tmp_path)
    shipping(tmp_path, monkeypatch, first, second)
    assert resolve_data_path("models/leg/scene.xml") == second / "models" / "leg" / "scene.xml"
    assert resolve_data_path("arm/scene.xml") == first / "models" / "arm" / "scene.xml"
    assert resources.models_dir() == first / "models"
    assert preset_names() == ["arm_sim", "leg_sim"]
    assert preset_path("leg_sim") == second / "presets" / "leg_sim.pbtxt"


def test_a_preset_two_plugins_ship_is_one_line_naming_both(tmp_path: Path, monkeypatch) -> None:
    for folder in (tmp_path / "a", tmp_path / "b"):
        (folder / "presets").mkdir(parents=True)
        (folder / "presets" / "twin.pbtxt").write_text('description: "x"\n')
    shipping(tmp_path, monkeypatch, tmp_path / "a", tmp_path / "b")
    assert preset_names() == ["twin"]
    with pytest.raises(UsageError) as error:
        preset_path("twin")
    assert str(error.value) == (
        "presets file 'twin.pbtxt' is shipped by both data folder 'a' from plugin 'p0' (dist-0) and data folder 'b' "
        "from plugin 'p1' (dist-1); disable one (JOSHUA_DISABLE_PLUGINS)"
    )


def test_without_a_plugin_shipping_models_a_missing_model_says_what_to_install(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(resources, "installed_folders", lambda: (DataFolder(tmp_path, "an empty data folder"),))
    with pytest.raises(ModelError, match="no installed plugin ships robot models; install one that does: pip install "):
        resolve_data_path("so_arm100/scene.xml")
    with pytest.raises(ModelError, match="^no installed plugin ships robot models; install one that does: pip install"):
        resources.models_dir()
