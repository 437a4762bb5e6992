"""Entry point of joshua-tasks: registers the robot tasks (`joshua_tasks.TASKS`) by name."""

from __future__ import annotations

from joshua_core import hookimpl
from joshua_core.plugins import Registrar
from joshua_tasks import TASKS


@hookimpl
def joshua_register_tasks(registry: Registrar) -> None:
    for name, spec in TASKS.items():
        registry.add(name, spec, spec.summary)
