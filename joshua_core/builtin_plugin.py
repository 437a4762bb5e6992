"""JOSHUA's own plugin: the components that ship with joshua-core and need no other distribution.

It registers no task and no data folder: a robot's tasks, models and presets live with the plugin that provides the
robot, or in a tasks distribution the core does not own.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from joshua_core.hookspecs import hookimpl
from joshua_core.tasks.grasping import GRASP_TERMS
from joshua_core.tasks.randomization import RANDOMIZATION_TERMS
from joshua_core.tasks.terms import BUILTIN_TERMS

if TYPE_CHECKING:
    from joshua_core.plugins import Registrar


@hookimpl
def joshua_register_modes(registry: Registrar) -> None:
    registry.add(
        "HEADLESS",
        "joshua_core.headless:HeadlessMode",
        "physics only, no rendering: steps the model, checks it stays finite, reports speed",
    )


@hookimpl
def joshua_register_terms(registry: Registrar) -> None:
    for name, function in {**BUILTIN_TERMS, **GRASP_TERMS, **RANDOMIZATION_TERMS}.items():
        registry.add(name, function, (function.__doc__ or "").strip().splitlines()[0])


@hookimpl
def joshua_register_commands(registry: Registrar) -> None:
    registry.add(
        "eval",
        "joshua_core.evaluation:EvalCommand",
        "roll out a trained policy: mean return, task metrics and an MP4 (joshua eval RUN_FOLDER, or a policy folder "
        "of a registered format)",
    )
