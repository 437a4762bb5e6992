"""JOSHUA's rendering floor: headless GL, frames, MP4/PNG writing, the viewer or a recording, the live viewer.

A library the MuJoCo backend, the modes, the mirror and the trainers share (no `joshua` entry point):

- headless GL: `choose_headless_gl`, `has_display`, `RenderingUnavailableError`, `render_optional` (a picture
  that is a by-product: warned about once, never an error);
- frames: `create_renderer`, `camera_id`, `render_with_commands` (3-d commands drawn as markers);
- files: `VideoWriter` (atomic H.264 MP4), `write_png`; `GridVideoWriter` (episodes tiled and labelled in one MP4),
  `episode_label`, `grid_shape`;
- display: `open_display` (the MuJoCo viewer when a display is usable, else an MP4 recording),
  `Display`, `ViewerDisplay`, `RecordingDisplay`, `display_usable`, `no_display_error`;
- training: `LiveViewer`, `open_viewer` (a few environments' poses in the viewer);
- browser: `WebDisplay`, `open_web_display`, `parse_web_address` (a simulation in a web page, via viser);
  `InteractivePage`, `InteractiveControls`, `open_interactive_page` (a live simulation with reset, speed,
  contact and frame display and body dragging);
  `TrainingPage`, `open_training_page` (a running training's environments and return curve in a web page).

Importing the package is light: mujoco, OpenCV and PyAV are imported the first time a name is used.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from joshua_render.display import (
        Display,
        RecordingDisplay,
        ViewerDisplay,
        display_usable,
        no_display_error,
        open_display,
    )
    from joshua_render.frames import camera_id, create_renderer, render_with_commands
    from joshua_render.gl import RenderingUnavailableError, choose_headless_gl, has_display, render_optional
    from joshua_render.grid import GridVideoWriter, episode_label, grid_shape
    from joshua_render.video import VideoWriter, write_png
    from joshua_render.viewer import LiveViewer, open_viewer
    from joshua_render.web import WebControls, WebDisplay, open_web_display, parse_web_address
    from joshua_render.web_interactive import InteractiveControls, InteractivePage, open_interactive_page
    from joshua_render.web_training import TrainingPage, open_training_page

__all__ = [
    "Display",
    "GridVideoWriter",
    "InteractiveControls",
    "InteractivePage",
    "LiveViewer",
    "RecordingDisplay",
    "RenderingUnavailableError",
    "TrainingPage",
    "VideoWriter",
    "ViewerDisplay",
    "WebControls",
    "WebDisplay",
    "camera_id",
    "choose_headless_gl",
    "create_renderer",
    "display_usable",
    "episode_label",
    "grid_shape",
    "has_display",
    "no_display_error",
    "open_display",
    "open_interactive_page",
    "open_training_page",
    "open_viewer",
    "open_web_display",
    "parse_web_address",
    "render_optional",
    "render_with_commands",
    "write_png",
]

# The module that defines each name of __all__: only that module (and what it needs) is imported.
_HOME = {
    "choose_headless_gl": "gl",
    "has_display": "gl",
    "RenderingUnavailableError": "gl",
    "render_optional": "gl",
    "camera_id": "frames",
    "create_renderer": "frames",
    "render_with_commands": "frames",
    "VideoWriter": "video",
    "write_png": "video",
    "GridVideoWriter": "grid",
    "episode_label": "grid",
    "grid_shape": "grid",
    "Display": "display",
    "RecordingDisplay": "display",
    "ViewerDisplay": "display",
    "display_usable": "display",
    "no_display_error": "display",
    "open_display": "display",
    "LiveViewer": "viewer",
    "open_viewer": "viewer",
    "WebControls": "web",
    "WebDisplay": "web",
    "open_web_display": "web",
    "parse_web_address": "web",
    "InteractiveControls": "web_interactive",
    "InteractivePage": "web_interactive",
    "open_interactive_page": "web_interactive",
    "TrainingPage": "web_training",
    "open_training_page": "web_training",
}


def __getattr__(name: str) -> Any:
    if name in _HOME:
        return getattr(importlib.import_module(f"joshua_render.{_HOME[name]}"), name)
    raise AttributeError(f"module 'joshua_render' has no attribute '{name}'")
