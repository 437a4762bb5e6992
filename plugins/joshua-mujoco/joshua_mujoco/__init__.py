"""JOSHUA's MuJoCo backend: `MuJoCoEngine`, one MuJoCo simulation behind the seed's API."""

from joshua_mujoco.gl import choose_headless_gl

choose_headless_gl()  # must run before mujoco is imported: mujoco picks its GL platform at import

from joshua_mujoco.engine import MuJoCoBackend, MuJoCoEngine  # noqa: E402

__all__ = ["MuJoCoBackend", "MuJoCoEngine"]
