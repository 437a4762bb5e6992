"""The package: every name of __all__ is found where it is defined, and importing the package stays light."""

from __future__ import annotations

import importlib
import subprocess
import sys

import joshua_render


def test_every_exported_name_resolves_to_its_home_module() -> None:
    assert sorted(joshua_render._HOME) == sorted(joshua_render.__all__)
    for name in joshua_render.__all__:
        value = getattr(joshua_render, name)
        home = importlib.import_module(f"joshua_render.{joshua_render._HOME[name]}")
        assert value is getattr(home, name) and value.__module__ == home.__name__, name


def test_importing_the_package_imports_neither_mujoco_nor_opencv() -> None:
    script = "import sys, joshua_render; print(sorted({'mujoco', 'cv2'} & set(sys.modules)))"
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60, check=True)
    assert result.stdout.strip() == "[]"
    script = "import sys; from joshua_render import VideoWriter; print('mujoco' in sys.modules, 'cv2' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60, check=True)
    assert result.stdout.split() == ["False", "True"]  # the video module needs OpenCV (PNG), not mujoco
