"""The CPU episode producer: joshua-mujoco's scripted pick-and-place controller (`PickPlaceScript`) driving an
arm's pick-and-place task (`SCRIPTED_TASKS`) in its batched CPU environments (mujoco.batch), each environment's
cameras rendered by the simulation's own renderer (`BatchedVectorEnv.render_frame`: the environment's randomized
model, the goal drawn as a green sphere, so that a policy trained on the images sees where to put the cube).

It simulates the task's own scene (so_arm100/pick_place.xml, so101/pick_place.xml), whatever scene a config names:
the MJX presets name pick_place_mjx.xml, whose contacts are set up for MJX, and there mujoco's CPU solver lets the
script place no cube (0 of 8 attempts, with and without the randomization), where the CPU scene places most."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from joshua_core.config_pb2 import TaskConfig
from joshua_core.errors import UsageError
from joshua_core.plugins import PluginHost
from joshua_lerobot.rollouts import EpisodeProducer, Rollout, frame_stride
from joshua_tasks import ARMS, pick_place

SCRIPTED_TASKS = tuple(pick_place(arm).name for arm in ARMS)  # the tasks PickPlaceScript solves


class ScriptedMuJoCoProducer(EpisodeProducer):
    """Rollouts of `PickPlaceScript` in `num_envs` CPU environments of `task`, one of `SCRIPTED_TASKS` (randomized by
    `task_config`'s events at full strength), `seed` starting the stream of resets;
    frames of `cameras` ("" = the model's first) at `size` (w, h), one every `fps`-th of a second."""

    def __init__(
        self,
        *,
        task: str,
        num_envs: int,
        cameras: Sequence[str],
        size: tuple[int, int],
        fps: int,
        seed: int,
        plugins: PluginHost,
        task_config: TaskConfig | None = None,
    ) -> None:
        from joshua_mujoco import make_vector_env

        self.env = make_vector_env(task, num_envs, seed=seed, task_config=task_config, plugins=plugins)
        simulation = self.env.simulation
        model, task = simulation.model, simulation.task
        try:
            self.stride = frame_stride(task.dt, fps)
            self.cameras = tuple(camera_name(model, name) for name in cameras)
            script_steps(task.episode_length)
        except UsageError:
            self.env.close()
            raise
        self.joint_names, self.joint_ranges, self.qpos_addresses = actuated_joints(model)
        self.num_envs, self.size, self.seed = num_envs, size, seed
        self.cube = model.body("cube").id
        self.task_text = task.spec.summary

    def rollouts(self) -> Iterator[Rollout]:
        from joshua_mujoco import PickPlaceScript

        env, simulation = self.env, self.env.simulation
        first = True
        while True:
            if not first:
                env.reset()  # the next draws of the same random stream: new cubes, goals and randomization
            first = False
            scripts = [PickPlaceScript(simulation.model, simulation.task) for _ in range(self.num_envs)]
            cubes = simulation.derived["xpos"][:, self.cube].copy()
            plans = [
                script.actions(simulation.qpos[i].copy(), cubes[i], simulation.commands["goal"][i].copy())
                for i, script in enumerate(scripts)
            ]
            actions = np.stack([next(plan)[1] for plan in plans])
            states, targets, frames = [], [], {camera: [[] for _ in plans] for camera in self.cameras}
            running, step = np.ones(self.num_envs, dtype=bool), 0
            while True:
                if step % self.stride == 0:
                    states.append(simulation.qpos[:, self.qpos_addresses].copy())
                    targets.append(np.stack([script.in_force for script in scripts]))
                    for camera, by_env in frames.items():
                        for i, kept in enumerate(by_env):
                            kept.append(env.render_frame(i, camera, *self.size))
                _, _, terminated, truncated, infos = env.step(actions)
                running &= ~(terminated | truncated)  # an ended environment has started another episode
                step += 1
                try:
                    actions = np.stack([plan.send(simulation.qpos[i].copy())[1] for i, plan in enumerate(plans)])
                except StopIteration:  # every plan has the same phases, so all end at this step
                    break
            success = running & (infos["metrics"]["success"] > 0)
            state_rows, target_rows = np.stack(states, axis=1), np.stack(targets, axis=1)
            for i in range(self.num_envs):
                yield Rollout(
                    states=state_rows[i],
                    actions=target_rows[i],
                    frames={camera: by_env[i] for camera, by_env in frames.items()},
                    success=bool(success[i]),
                )

    def close(self) -> None:
        self.env.close()


def camera_name(model: Any, name: str) -> str:
    """The model camera `name` ("": the model's first); one the model lacks is a UsageError listing its cameras."""
    from joshua_render import camera_id

    if not name and not model.ncam:
        raise UsageError("the model has no camera to record; it needs one in its MJCF")
    return str(model.camera(camera_id(model, name or None)).name)


def actuated_joint(model: Any, actuator: int) -> int:
    """The joint an actuator drives (its control is that joint's target, in the joint's units)."""
    import mujoco

    if int(model.actuator_trntype[actuator]) != int(mujoco.mjtTrn.mjTRN_JOINT):
        raise UsageError(f"actuator '{model.actuator(actuator).name}' drives no joint: its target is no joint value")
    return int(model.actuator_trnid[actuator, 0])


def actuated_joints(model: Any) -> tuple[tuple[str, ...], dict[str, tuple[float, float]], NDArray[np.intp]]:
    """The joints the model's actuators drive, in actuator order: their names, the model's joint ranges by name (the
    LeRobot units map onto them) and their qpos addresses."""
    from joshua_modes import model_joint_ranges

    joints = [actuated_joint(model, actuator) for actuator in range(model.nu)]
    names = tuple(model.joint(joint).name for joint in joints)
    return names, model_joint_ranges(model), np.array([model.jnt_qposadr[joint] for joint in joints])


def script_steps(episode_length: int) -> int:
    """Control steps of the scripted pick-and-place; a UsageError when the task's episodes end before it does."""
    from joshua_mujoco import pick_place_phases

    steps = sum(phase.steps for phase in pick_place_phases(np.zeros(3), np.zeros(3)))
    if steps > episode_length:
        raise UsageError(
            f"the scripted controller needs {steps} control steps, the task's episodes end after "
            f"{episode_length}: raise training.task_config.episode_length"
        )
    return steps
