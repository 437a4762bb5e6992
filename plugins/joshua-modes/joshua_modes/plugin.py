"""Entry point of joshua-modes: registers the OFFSCREEN, PASSIVE and INTERACTIVE modes and their options.

Imports nothing heavy: the options module (options_pb2) imports only protobuf and the core schema. The options
register no settings function: each is its own settings, the message a mode gets from `RunContext.settings`.
"""

from __future__ import annotations

from joshua_core import hookimpl
from joshua_core.plugins import Registrar


@hookimpl
def joshua_register_modes(registry: Registrar) -> None:
    registry.add(
        "OFFSCREEN",
        "joshua_modes.offscreen:OffscreenMode",
        "headless rendering of a trajectory replay to MP4/PNG (depth, segmentation optional)",
    )
    registry.add(
        "PASSIVE",
        "joshua_modes.passive:PassiveMode",
        "trajectory CSV validation and replay in the viewer, or to MP4 without a display",
    )
    registry.add(
        "INTERACTIVE",
        "joshua_modes.interactive:InteractiveMode",
        "the MuJoCo viewer with the robot held at its keyframe by its actuators",
    )


@hookimpl
def joshua_register_options(registry: Registrar) -> None:
    registry.add("offscreen", "joshua_modes.options_pb2:offscreen", "OFFSCREEN: camera, fps, outputs, depth, shadows")
    registry.add("replay", "joshua_modes.options_pb2:replay", "PASSIVE, OFFSCREEN: trajectory validation and replay")
    registry.add("viewer", "joshua_modes.options_pb2:viewer", "PASSIVE, INTERACTIVE: viewer window or recorded video")
