"""JOSHUA's robot tasks: locomotion of the Ant and the three-legged walker, reach and pick-and-place of the
SO-ARM100 and SO-101 arms, on the robot models this distribution ships with the presets (`joshua_tasks.data`;
docs/tasks.md describes each task).

The core keeps only the task machinery (`joshua_core.tasks`: TaskSpec, the term library, the checks when a
task is built); these are tasks written with it, registered by this distribution's plugin (`joshua_tasks.plugin`).
"""

from __future__ import annotations

from joshua_tasks.arms import ARMS, SO101, SO_ARM100, Arm, pick_place, reach
from joshua_tasks.locomotion import ANT_LOCOMOTION, TRILEG_LOCOMOTION

TASKS = {
    spec.name: spec
    for spec in (ANT_LOCOMOTION, TRILEG_LOCOMOTION, *(task(arm) for arm in ARMS for task in (reach, pick_place)))
}

__all__ = [
    "ANT_LOCOMOTION",
    "ARMS",
    "SO101",
    "SO_ARM100",
    "TASKS",
    "TRILEG_LOCOMOTION",
    "Arm",
    "pick_place",
    "reach",
]
