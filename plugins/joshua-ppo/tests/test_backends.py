"""The ppo trainer takes its environments from the backend the config names: it trains, films and evaluates on a
backend registered by a test plugin (not `mjx`) that provides JAX environments, and a backend that provides
none is a ConfigError naming the backends that do."""

from __future__ import annotations

import json
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest

import joshua_ppo.plugin
import joshua_tasks.plugin
from joshua_core import builtin_plugin, hookimpl
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.interfaces import Backend, EnvKind, EnvSpec
from joshua_core.plugins import PluginHost, PluginInfo
from joshua_core.resources import resolve_data_path
from joshua_core.run_context import RunContext
from joshua_core.tasks import build_task, load_task_spec
from joshua_ppo import options_pb2
from joshua_ppo.options_pb2 import PpoOptions

MADE: list[EnvSpec] = []  # every EnvSpec the test backend was asked for


class JaxTestBackend(Backend):
    """A third party's JAX environments: joshua-mjx's exported MjxEnv, built by the plugin itself."""

    def create_engine(
        self, model_path: Path, plugins: PluginHost, *, render_width: int = 640, render_height: int = 480
    ) -> Any:
        raise NotImplementedError

    def create_envs(self, spec: EnvSpec, kind: EnvKind, plugins: PluginHost) -> Any:
        from joshua_mjx import MjxEnv, Physics
        from joshua_mujoco import compile_model

        MADE.append(spec)
        task = load_task_spec(spec.task, plugins)
        path = spec.model_path or resolve_data_path(task.model_path)
        model = compile_model(path)
        built = build_task(task, model, plugins, spec.task_config)
        # MuJoCo Warp's physics: the plumbing is the subject, and Warp's programs compile far sooner than MJX-JAX's
        return MjxEnv(built, model, spec.num_envs, source=path, devices=spec.devices, physics=Physics("warp"))


class NothingBackend(JaxTestBackend):
    """A backend that provides no environments."""


@hookimpl
def joshua_register_backends(registry: Any) -> None:
    registry.add("test_jax", JaxTestBackend, "JAX environments of a test plugin", env_kinds=("jax",))
    registry.add("test_nothing", NothingBackend, "no environments")


def host() -> PluginHost:
    """The core, the ppo trainer, the robot tasks and the test backends; neither joshua-mujoco's nor joshua-mjx's
    plugin."""
    test_plugin = ModuleType("test_backends")
    test_plugin.joshua_register_backends = joshua_register_backends  # type: ignore[attr-defined]
    return PluginHost(
        [
            (PluginInfo("core", "joshua-core", "0", "builtin"), builtin_plugin),
            (PluginInfo("ppo", "joshua-ppo", "0", "joshua_ppo.plugin"), joshua_ppo.plugin),
            (PluginInfo("tasks", "joshua-tasks", "0", "joshua_tasks.plugin"), joshua_tasks.plugin),
            (PluginInfo("test", "test-backends", "0", "test_backends"), test_plugin),
        ]
    )


def training(backend: str) -> TrainingConfig:
    """Two iterations of 4 Ants x 5 steps, a video after the second."""
    config = TrainingConfig(
        trainer="ppo",
        backend=backend,
        task="ant_locomotion",
        model_path=str(resolve_data_path("ant/ant_mjx.xml")),
        num_envs=4,
        num_steps=5,
        num_epochs=1,
        minibatch_size=20,
        total_timesteps=40,
    )
    config.task_config.episode_length = 3
    config.run_name = "third_party"
    config.hidden_sizes.extend([16])
    options = config.Extensions[options_pb2.ppo]
    options.video_interval = 2
    options.video_steps = 4
    options.viewer = PpoOptions.OFF
    return config


@pytest.mark.slow
def test_ppo_trains_films_and_evaluates_on_a_third_party_jax_backend(tmp_path: Path) -> None:
    plugins = host()
    context = RunContext(plugins, tmp_path)
    checkpoint = plugins.trainer("ppo").train(training("test_jax"), context)
    assert checkpoint == tmp_path / "third_party_step_40"
    metrics = json.loads((checkpoint / "metrics.json").read_text())
    assert [record["step"] for record in metrics["history"]] == [20, 40]
    assert (tmp_path / "third_party" / "videos" / "step_40.mp4").stat().st_size > 0
    results = plugins.trainer("ppo").evaluate(
        tmp_path / "third_party", episodes=2, seed=0, video_path=None, context=context
    )
    assert np.isfinite(results.returns).all() and list(results.lengths) == [3, 3]  # one result per episode
    assert [spec.num_envs for spec in MADE] == [4, 1, 2]  # training, the video, the evaluation


def test_a_backend_without_jax_environments_is_a_config_error_naming_those_with_them(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as caught:
        host().trainer("ppo").train(training("test_nothing"), RunContext(host(), tmp_path))
    assert str(caught.value) == (
        "trainer 'ppo' needs JAX environments, which backend 'test_nothing' does not provide; "
        "backends that do: test_jax"
    )
    assert not any(tmp_path.iterdir())
