"""The sb3 trainer takes its environments from the backend the config names: it trains and evaluates on a
backend registered by a test plugin (not `mujoco`) that provides NUMPY environments, and a backend that
provides none is a ConfigError naming the backends that do."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType
from typing import Any

import gymnasium
import numpy as np
import pytest

import joshua_sb3.plugin
import joshua_tasks.plugin
from joshua_core import builtin_plugin, hookimpl
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.interfaces import Backend, EnvKind, EnvSpec
from joshua_core.plugins import PluginHost, PluginInfo
from joshua_core.resources import resolve_data_path
from joshua_core.run_context import RunContext


class ThirdPartyEnvs(gymnasium.vector.VectorWrapper):
    """A third party's NUMPY environments: here the mujoco backend's, wrapped, counting the steps taken."""

    steps = 0

    def step(self, actions: Any) -> Any:
        ThirdPartyEnvs.steps += 1
        return self.env.step(actions)

    def render_frame(self, *args: Any, **kwargs: Any) -> Any:
        return self.env.render_frame(*args, **kwargs)


class NumpyTestBackend(Backend):
    def create_engine(
        self, model_path: Path, plugins: PluginHost, *, render_width: int = 640, render_height: int = 480
    ) -> Any:
        raise NotImplementedError

    def create_envs(self, spec: EnvSpec, kind: EnvKind, plugins: PluginHost) -> ThirdPartyEnvs:
        from joshua_mujoco import MuJoCoBackend

        return ThirdPartyEnvs(MuJoCoBackend().create_envs(spec, kind, plugins))


class NothingBackend(NumpyTestBackend):
    """A backend that provides no environments."""


@hookimpl
def joshua_register_backends(registry: Any) -> None:
    registry.add("test_np", NumpyTestBackend, "NUMPY environments of a test plugin", env_kinds=("numpy",))
    registry.add("test_nothing", NothingBackend, "no environments")


def host() -> PluginHost:
    """The core, the sb3 trainer, the robot tasks and the test backends; neither joshua-mujoco's nor joshua-mjx's
    plugin."""
    test_plugin = ModuleType("test_backends")
    test_plugin.joshua_register_backends = joshua_register_backends  # type: ignore[attr-defined]
    return PluginHost(
        [
            (PluginInfo("core", "joshua-core", "0", "builtin"), builtin_plugin),
            (PluginInfo("sb3", "joshua-sb3", "0", "joshua_sb3.plugin"), joshua_sb3.plugin),
            (PluginInfo("tasks", "joshua-tasks", "0", "joshua_tasks.plugin"), joshua_tasks.plugin),
            (PluginInfo("test", "test-backends", "0", "test_backends"), test_plugin),
        ]
    )


def training(backend: str, run_name: str) -> TrainingConfig:
    config = TrainingConfig(
        trainer="sb3",
        backend=backend,
        task="so_arm100_reach",
        model_path=str(resolve_data_path("so_arm100/scene.xml")),
        num_envs=4,
        total_timesteps=4 * 16 * 2,
        num_steps=16,
        num_epochs=1,
        minibatch_size=32,
    )
    config.task_config.episode_length = 10
    config.run_name = run_name
    config.hidden_sizes.extend([16])
    return config


def test_sb3_trains_and_evaluates_on_a_third_party_numpy_backend(tmp_path: Path) -> None:
    plugins = host()
    context = RunContext(plugins, tmp_path)
    checkpoint = plugins.trainer("sb3").train(training("test_np", "third_party"), context)
    assert checkpoint.is_dir() and ThirdPartyEnvs.steps >= 2 * 16
    results = plugins.trainer("sb3").evaluate(
        tmp_path / "third_party", episodes=2, seed=3, video_path=None, context=context
    )
    assert np.isfinite(results.returns).all() and list(results.lengths) == [10, 10]  # one result per episode


def test_a_backend_without_numpy_environments_is_a_config_error_naming_those_with_them(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as caught:
        host().trainer("sb3").train(training("test_nothing", "nothing"), RunContext(host(), tmp_path))
    assert str(caught.value) == (
        "trainer 'sb3' needs NUMPY environments, which backend 'test_nothing' does not provide; "
        "backends that do: test_np"
    )
