"""Entry point of joshua-tasks: registers the robot tasks (`joshua_tasks.TASKS`) by name, and the folder of the
robot models and presets they are for (`joshua_tasks.data`)."""

from __future__ import annotations

from joshua_core import hookimpl
from joshua_core.plugins import Registrar
from joshua_tasks import TASKS


@hookimpl
def joshua_register_tasks(registry: Registrar) -> None:
    for name, spec in TASKS.items():
        registry.add(name, spec, spec.summary)


@hookimpl
def joshua_register_data_folders(registry: Registrar) -> None:
    registry.add(
        "robots",
        "joshua_tasks.data:ROOT",
        "models/ (SO-ARM100, SO-101, Ant, trileg; their USD, a reach policy, a trajectory) and presets/",
    )
