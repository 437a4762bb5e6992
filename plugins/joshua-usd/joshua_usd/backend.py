"""The `usd` backend: MuJoCo physics for robots described in USD (Isaac's format), or in any format a
plugin reads (`joshua_mujoco.read_spec`), MJCF included.

It adds no physics of its own: engines are joshua-mujoco's `MuJoCoEngine`, NUMPY environments its
`mujoco.batch` ones, JAX environments joshua-mjx's (an optional dependency, imported only then).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from joshua_core.errors import ConfigError
from joshua_core.interfaces import DEFAULT_RENDER_HEIGHT, DEFAULT_RENDER_WIDTH, Backend, EnvKind, EnvSpec
from joshua_mujoco import MuJoCoBackend, MuJoCoEngine

if TYPE_CHECKING:
    from joshua_core.plugins import PluginHost

MJX_MISSING = (
    "backend usd: JAX environments need joshua-mjx, which is not installed; "
    "install joshua-mjx (pip install 'joshua-usd[mjx]')"
)


class UsdBackend(Backend):
    """The `usd` backend: a MuJoCoEngine per model; NUMPY (mujoco.batch) and JAX (MJX) environments."""

    def create_engine(
        self,
        model_path: Path,
        plugins: PluginHost,
        *,
        render_width: int = DEFAULT_RENDER_WIDTH,
        render_height: int = DEFAULT_RENDER_HEIGHT,
    ) -> MuJoCoEngine:
        return MuJoCoEngine(model_path, render_width=render_width, render_height=render_height, plugins=plugins)

    def create_envs(self, spec: EnvSpec, kind: EnvKind, plugins: PluginHost) -> Any:
        if kind is EnvKind.NUMPY:
            return MuJoCoBackend().create_envs(spec, kind, plugins)
        return mjx_backend().create_envs(spec, kind, plugins)


def mjx_backend() -> Backend:
    """joshua-mjx's backend, or a one-line ConfigError saying to install it."""
    try:
        from joshua_mjx import MjxBackend
    except ModuleNotFoundError as error:
        if error.name != "joshua_mjx":
            raise
        raise ConfigError(MJX_MISSING) from None
    return MjxBackend()
