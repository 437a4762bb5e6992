"""What a mode or trainer gets besides its config: the plugins of this run and where to write.

Above the plugin host: a `RunContext` holds the host and asks it for the backend a config names, so that modes
and trainers get engines and environments without importing a backend or discovering plugins again, and the
settings of the options a config sets, resolved once per run.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from joshua_core.defaults import training_plugins
from joshua_core.errors import ConfigError
from joshua_core.interfaces import Engine, EnvKind, EnvSpec, render_size
from joshua_core.kinds import Kind

if TYPE_CHECKING:
    from google.protobuf.message import Message

    from joshua_core.config_pb2 import SimulationConfig, TrainingConfig
    from joshua_core.plugins import PluginHost


@dataclass(frozen=True)
class RunContext:
    """What a mode or trainer gets besides its config: the plugins of this run and where to write."""

    plugins: PluginHost
    output_dir: Path
    # The settings already resolved, by option name and the config they were resolved from (its serialized bytes).
    _settings: dict[tuple[str, bytes], Any] = field(default_factory=dict, init=False, repr=False, compare=False)

    def settings(self, name: str, config: Message) -> Any:
        """The settings of the option `name` in `config` (the SimulationConfig or TrainingConfig it extends), as the
        option's settings function makes them (`joshua_register_options`) from the option and `config`: resolved on
        the first call for that config, the same object on every later one. An option registered without a settings
        function is its own settings: its message (every field at its default when `config` sets none)."""
        key = (name, config.SerializeToString(deterministic=True))
        if key not in self._settings:
            extension = self.plugins.options().find(config.DESCRIPTOR, name)
            if extension is None:
                raise ConfigError(f"{config.DESCRIPTOR.name} has no option '{name}': is its plugin installed?")
            options = config.Extensions[extension]
            make = self.plugins.component(Kind.OPTIONS, name).load_settings()
            self._settings[key] = options if make is None else make(options, config)
        return self._settings[key]

    def create_engine(self, simulation: SimulationConfig) -> Engine:
        """Engine for a finalized simulation config, from the backend it names, reset to the config's keyframe
        (the model's initial state when none is named); an unknown keyframe is a ConfigError listing them."""
        backend = self.plugins.backend(simulation.backend)
        width, height = render_size(simulation)
        engine = backend.create_engine(
            Path(simulation.model_path), self.plugins, render_width=width, render_height=height
        )
        try:
            engine.reset(simulation.keyframe or None)
        except KeyError as error:
            engine.close()
            raise ConfigError(f"simulation.keyframe: {error.args[0]}") from None
        return engine

    def create_envs(
        self,
        training: TrainingConfig,
        kind: EnvKind,
        *,
        num_envs: int | None = None,
        seed: int | None = None,
        devices: Sequence[Any] | None = None,
        training_envs: bool = False,
    ) -> Any:
        """Environments of `kind` for a finalized training config, from the backend it names; a backend that
        does not provide `kind` is a ConfigError naming those that do. `num_envs`, `seed` replace the config's;
        `devices` (JAX environments) are the devices to spread them over (None: every visible one).
        `training_envs`: the environments a trainer learns on, whose episodes are desynchronised unless
        `training.synchronized_episodes` and whose events follow the task's randomization curriculum
        (evaluation wants whole first episodes at full strength: leave it False)."""
        trainer, backend = training_plugins(training)
        self.plugins.check_env_kinds(trainer, backend, needs=(kind,))
        desync = training_envs and not training.synchronized_episodes
        spec = replace(
            EnvSpec.from_training(training, num_envs=num_envs, seed=seed),
            devices=devices,
            desync_episodes=desync,
            curriculum=training_envs,
        )
        return self.plugins.backend(backend).create_envs(spec, kind, self.plugins)
