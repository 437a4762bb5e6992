"""Fixtures for joshua-render: plain helpers live in render_testing.py (a unique name, so it cannot clash with
another plugin's tests); Xvfb and screenshots are in the root conftest."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from render_testing import SCENE, SceneEngine  # noqa: E402


@pytest.fixture
def engine() -> Iterator[SceneEngine]:
    """The SO-ARM100 scene at its home keyframe, rendering 160x120."""
    with SceneEngine(SCENE, width=160, height=120) as engine:
        engine.reset("home")
        yield engine
