"""Entry point of joshua-lerobot: registers the "lerobot" trajectory reader, `joshua lerobot-export`,
`joshua lerobot-units`, `joshua demos` and the "lerobot" policy format (`joshua eval` of a LeRobot policy folder)."""

from __future__ import annotations

from joshua_core import hookimpl
from joshua_core.plugins import Registrar


@hookimpl
def joshua_register_trajectory_readers(registry: Registrar) -> None:
    registry.add(
        "lerobot",
        "joshua_lerobot.reader:LeRobotReader",
        "LeRobot dataset folders (v3.0, meta/info.json): observation.state -> positions, action -> targets",
    )


@hookimpl
def joshua_register_commands(registry: Registrar) -> None:
    registry.add(
        "lerobot-export",
        "joshua_lerobot.export:LeRobotExportCommand",
        "replay a trajectory (CSV or dataset) on a model, render it and write a LeRobot dataset with camera videos",
    )
    registry.add(
        "lerobot-units",
        "joshua_lerobot.units_command:LeRobotUnitsCommand",
        "record which units (degrees or range, with the calibration) a LeRobot dataset's SO-100 values are in",
    )
    registry.add(
        "demos",
        "joshua_lerobot.demos:DemosCommand",
        "roll the scripted pick-and-place out over randomized episodes and write the successful ones as a LeRobot "
        "dataset with camera videos",
    )


@hookimpl
def joshua_register_policy_formats(registry: Registrar) -> None:
    registry.add(
        "lerobot",
        "joshua_lerobot.policy_eval:LeRobotPolicyFormat",
        "LeRobot pretrained-policy folders (config.json with a policy type, model.safetensors), run by a Python "
        "with lerobot (--lerobot-python) on the task's rendered cameras and joint state",
    )
