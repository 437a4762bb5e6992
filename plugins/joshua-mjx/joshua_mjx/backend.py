"""The `mjx` backend: an `MjxEngine` per model (joshua_mjx.engine) and `MjxEnv`s for training (joshua_mjx.env).

A module of its own, above both: the environments use the engine's model loading, and the backend uses both.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from joshua_core.errors import ConfigError
from joshua_core.interfaces import DEFAULT_RENDER_HEIGHT, DEFAULT_RENDER_WIDTH, Backend, EnvKind, EnvSpec
from joshua_jax import use_compile_cache
from joshua_mjx.engine import MjxEngine, mjx_variant
from joshua_mjx.env import MjxEnv, mjx_envs
from joshua_mjx.impl import Physics

if TYPE_CHECKING:
    from joshua_core.plugins import PluginHost


class MjxBackend(Backend):
    """The `mjx` backend: an `MjxEngine` per model, and `MjxEnv`s (EnvKind.JAX, in joshua_mjx.env) for training."""

    def create_engine(
        self,
        model_path: Path,
        plugins: PluginHost,
        *,
        render_width: int = DEFAULT_RENDER_WIDTH,
        render_height: int = DEFAULT_RENDER_HEIGHT,
    ) -> MjxEngine:
        use_compile_cache()  # before the engine's step compiles
        return MjxEngine(model_path, render_width=render_width, render_height=render_height, plugins=plugins)

    def create_envs(self, spec: EnvSpec, kind: EnvKind, plugins: PluginHost) -> MjxEnv:
        if kind is not EnvKind.JAX:
            raise ConfigError(f"backend mjx provides JAX environments, not {kind.name}")
        use_compile_cache()  # before the environments' reset and step compile
        Physics.from_training(spec.training).leave_memory_to_warp()  # before JAX starts its backends, if it has not
        return mjx_envs(spec, plugins)

    def model_variant(self, model_path: Path) -> Path:
        return mjx_variant(model_path)
