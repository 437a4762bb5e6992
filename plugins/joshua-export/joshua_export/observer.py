"""The observation of one robot state, computed by the task's own observation terms, as in training.

A deployed policy must see what it saw in simulation. Rather than re-implement each term for the real
robot, `Observer` keeps the task's MuJoCo model: a deployer sets qpos (from encoders) and qvel, MuJoCo
computes the derived state (`mj_forward`: body and site positions, sensors), and the built task's terms
(`joshua_core.tasks`) turn that into the observation. The contract's term list and slices come from the
same `Observer` at export time, so the two agree by construction.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from joshua_core.plugins import PluginHost
from joshua_core.tasks import Task, TermContext


def model_sha256(model: mujoco.MjModel) -> str:
    """SHA-256 of the compiled model: every array and setting (meshes and included files count, not file
    formatting), but not where its asset files lie (`paths`, their addresses and the buffer size follow the
    absolute paths, which differ between checkouts): a contract written on one machine matches the model on
    another."""
    path_dependent = ("paths", "npaths", "mesh_pathadr", "nbuffer")
    digest = hashlib.sha256()
    for owner, prefix in ((model, ""), (model.opt, "opt.")):
        for name in sorted(dir(owner)):
            if name.startswith("_") or name in path_dependent:
                continue
            value = getattr(owner, name)
            if isinstance(value, np.ndarray | bytes | int | float):
                digest.update(f"{prefix}{name}".encode())
                is_array = isinstance(value, np.ndarray)
                digest.update(np.ascontiguousarray(value).tobytes() if is_array else repr(value).encode())
    return digest.hexdigest()


class Observer:
    """Observations of one robot state through a built task (one environment)."""

    def __init__(self, task: Task, model: mujoco.MjModel) -> None:
        self.task = task
        self.model = model
        self.data = mujoco.MjData(model)

    @classmethod
    def load(cls, task: str, model_path: Path | None, plugins: PluginHost, task_config: Any = None) -> Observer:
        """The task built on its model (`model_path`, resolved; None: the task's own), as the MuJoCo backend
        builds it for training."""
        from joshua_mujoco import load_task_model

        built, model = load_task_model(task, model_path, plugins, task_config)
        return cls(built, model)

    def context(
        self,
        qpos: ArrayLike,
        qvel: ArrayLike,
        *,
        commands: Mapping[str, ArrayLike],
        action: ArrayLike,
        prev_action: ArrayLike | None = None,
        prev_qpos: ArrayLike | None = None,
        ctrl: ArrayLike | None = None,
    ) -> TermContext:
        """The TermContext of the state (qpos, qvel): derived fields computed by MuJoCo, arrays with one row;
        `ctrl`, the controls in force (servo targets), defaults to the task's initial ones."""
        data = self.data
        data.qpos[:] = qpos
        data.qvel[:] = qvel
        mujoco.mj_forward(self.model, data)
        if "cfrc_ext" in self.task.fields:
            mujoco.mj_rnePostConstraint(self.model, data)
        action = np.asarray(action, np.float64)
        return TermContext(
            xp=np,
            dt=self.task.dt,
            qpos=data.qpos[None].copy(),
            qvel=data.qvel[None].copy(),
            prev_qpos=np.asarray(data.qpos if prev_qpos is None else prev_qpos, np.float64)[None],
            xpos=data.xpos[None].copy(),
            xquat=data.xquat[None].copy(),
            site_xpos=data.site_xpos[None].copy(),
            sensordata=data.sensordata[None].copy(),
            cfrc_ext=data.cfrc_ext[None].copy(),
            ctrl=np.asarray(self.task.initial_ctrl if ctrl is None else ctrl, np.float64)[None],
            action=action[None],
            prev_action=np.asarray(np.zeros_like(action) if prev_action is None else prev_action, np.float64)[None],
            episode_step=np.zeros(1, np.int64),
            commands={name: np.asarray(commands[name], np.float64).reshape(1, -1) for name in self.task.commands},
        )

    def observe(self, ctx: TermContext) -> NDArray[np.float32]:
        """The observation vector (observation_size,) of a one-row context, in the policy's float32."""
        return np.asarray(self.task.observe(ctx)[0], np.float32)

    def initial_context(self) -> TermContext:
        """The task's initial state (its keyframe) with zero commands and actions."""
        zeros = {name: np.zeros(size) for name, size in self.task.commands.items()}
        return self.context(
            self.task.initial_qpos, self.task.initial_qvel, commands=zeros, action=np.zeros(self.task.action_size)
        )

    def term_slices(self) -> list[tuple[str, str, int, int]]:
        """(name in the task, registered term, start, stop) of each observation term in the observation vector."""
        ctx = self.initial_context()
        terms = {spec.key: spec.term for spec in self.task.spec.observations}
        slices, start = [], 0
        for term in self.task.observation_terms:
            width = int(np.asarray(term(ctx)).reshape(1, -1).shape[1])
            slices.append((term.name, terms[term.name], start, start + width))
            start += width
        return slices
