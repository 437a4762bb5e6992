"""JOSHUA's MuJoCo backend: `MuJoCoEngine`, one MuJoCo simulation behind the `Engine` API, batched
CPU environments of any task (`BatchedVectorEnv`, EnvKind.NUMPY), and a scripted pick-and-place controller
(`PickPlaceScript`, inverse kinematics on a CPU model) for the SO-ARM100's pick-and-place task.

The package itself stays light (the `joshua` entry point imports `joshua_mujoco.plugin`);
mujoco is imported the first time one of the names below is used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from joshua_mujoco.engine import MuJoCoBackend, MuJoCoEngine
    from joshua_mujoco.models import compile_model, read_spec
    from joshua_mujoco.physics import BatchPhysics, MuJoCoBatchPhysics
    from joshua_mujoco.scripted import (
        JAW_CLOSED,
        JAW_OPEN,
        Phase,
        PickPlaceScript,
        PlannerPool,
        ScriptPlan,
        corrected_targets,
        integrate_sag,
        pick_place_phases,
    )
    from joshua_mujoco.vector import (
        BatchedSimulation,
        BatchedVectorEnv,
        load_task_model,
        make_vector_env,
        vector_env_from_config,
    )

__all__ = [
    "MuJoCoBackend",
    "MuJoCoEngine",
    "compile_model",
    "read_spec",
    "BatchPhysics",
    "MuJoCoBatchPhysics",
    "BatchedSimulation",
    "BatchedVectorEnv",
    "load_task_model",
    "make_vector_env",
    "vector_env_from_config",
    "JAW_CLOSED",
    "JAW_OPEN",
    "Phase",
    "PickPlaceScript",
    "PlannerPool",
    "pick_place_phases",
    "ScriptPlan",
    "corrected_targets",
    "integrate_sag",
]
_MODULES = {
    "compile_model": "models",
    "read_spec": "models",
    "MuJoCoBackend": "engine",
    "MuJoCoEngine": "engine",
    "BatchPhysics": "physics",
    "MuJoCoBatchPhysics": "physics",
    "JAW_CLOSED": "scripted",
    "JAW_OPEN": "scripted",
    "Phase": "scripted",
    "PickPlaceScript": "scripted",
    "PlannerPool": "scripted",
    "pick_place_phases": "scripted",
    "ScriptPlan": "scripted",
    "corrected_targets": "scripted",
    "integrate_sag": "scripted",
}


def __getattr__(name: str) -> Any:
    if name in __all__:
        import importlib

        module = _MODULES.get(name, "vector")
        return getattr(importlib.import_module(f"joshua_mujoco.{module}"), name)
    raise AttributeError(f"module 'joshua_mujoco' has no attribute '{name}'")
