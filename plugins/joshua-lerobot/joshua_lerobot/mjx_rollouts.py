"""The GPU episode producer: joshua-mujoco's scripted pick-and-place controller (`PickPlaceScript`) driving
an arm's pick-and-place task in the `mjx` backend's JAX environments on MuJoCo Warp, each environment's cameras
rendered by Warp's batched ray tracer inside the compiled step (joshua_mjx's cameras, `every_steps` = the frame
stride).

Where the script runs: its inverse kinematics (damped least squares on a CPU model, up to 200 iterations a step)
depends only on where the arm, the cube and the goal start, not on what the servos measure on the way
(`ScriptPlanner.plan`), so the host solves it once per attempt, for the next batch while the device rolls the
current one out (a thread handing the attempts to `PlannerPool`'s processes, one per core but one). What does read
the measurements, the sag correction and the mapping of servo targets to actions, runs inside the compiled rollout
with jax.numpy (`corrected_targets`, `integrate_sag`, the task's own `action_for_ctrl`): a jitted `lax.scan` over a
chunk of dataset rows, `stride` control steps each, and the chunk's joint positions, targets and frames come to the
host in one transfer. The rollout never waits on the host between steps; the host's planning, a CPU core's work
per attempt, bounds the rate when the device outpaces it.

It simulates the MJX scene (the config's model, else pick_place_mjx.xml): MJX's solver lets the script place the
cube there, where mujoco's CPU solver does not (scripted_rollouts.py simulates the CPU scene).

Memory: the host holds one batch's frames, num_envs x rows x H x W x 3 bytes per camera (rows: one per `stride`
steps of the 300-step attempt; 1.8 MB per environment and camera at 64x64 and 25 fps), at most MAX_BATCH_BYTES;
the device two chunks' (one being pulled while the next runs), at most CHUNK_BYTES each, besides the environments'
state and Warp's render buffers (joshua_mjx.cameras).
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from joshua_core.config_pb2 import TaskConfig, TrainingConfig
from joshua_core.errors import UsageError
from joshua_core.plugins import PluginHost
from joshua_core.progress import status_line
from joshua_core.resources import resolve_data_path
from joshua_lerobot.rollouts import EpisodeProducer, Rollout, frame_stride
from joshua_lerobot.scripted_rollouts import actuated_joints, camera_name, script_steps

CHUNK_BYTES = 256 * 2**20  # frames a compiled chunk keeps on the device before they are pulled
MAX_BATCH_BYTES = 16 * 2**30  # frames of one batch on the host


class ScriptedMjxProducer(EpisodeProducer):
    """Rollouts of `PickPlaceScript` in `num_envs` MuJoCo Warp environments of `training`'s task (the model,
    events and Warp capacities `training` names; events at full strength), `seed` starting the stream of resets;
    frames of `cameras` ("" = the model's first) at `size` (w, h), one every `fps`-th of a second."""

    def __init__(
        self,
        *,
        num_envs: int,
        cameras: Sequence[str],
        size: tuple[int, int],
        fps: int,
        seed: int,
        plugins: PluginHost,
        training: TrainingConfig,
    ) -> None:
        import jax

        from joshua_core.tasks import build_task, load_task_spec
        from joshua_mjx import WARP, MjxEnv, Physics, mjx_variant
        from joshua_mujoco import PlannerPool, compile_model

        physics = replace(Physics.from_training(training), impl=WARP)  # cameras render on Warp only
        physics.leave_memory_to_warp()
        spec = load_task_spec(training.task, plugins)
        path = resolve_data_path(training.model_path) if training.model_path else mjx_variant(spec.model_path)
        model = compile_model(path, plugins=plugins)
        task_config = training.task_config if training.HasField("task_config") else None
        self.stride = frame_stride(build_task(spec, model, plugins, task_config).dt, fps)
        self.cameras = tuple(camera_name(model, name) for name in cameras)
        task = build_task(spec, model, plugins, with_cameras(task_config, self.cameras, size, self.stride))
        self.steps = script_steps(task.episode_length)
        self.rows = -(-self.steps // self.stride)
        frame_bytes = size[0] * size[1] * 3 * len(self.cameras)
        if num_envs * self.rows * frame_bytes > MAX_BATCH_BYTES:
            most = MAX_BATCH_BYTES // (self.rows * frame_bytes)
            raise UsageError(
                f"--num-envs {num_envs} would hold {num_envs * self.rows * frame_bytes / 2**30:.1f} GiB of frames per "
                f"batch, more than {MAX_BATCH_BYTES / 2**30:g}: at most {most} at this size, fps and cameras"
            )
        self.chunk_rows = max(1, min(self.rows, CHUNK_BYTES // (num_envs * frame_bytes)))
        self.chunks = -(-self.rows // self.chunk_rows)
        self.device = jax.devices()[0]  # Warp steps one device's environments
        self.env = MjxEnv(task, model, num_envs, source=path, devices=[self.device], physics=physics)
        self.joint_names, self.joint_ranges, self.qpos_addresses = actuated_joints(model)
        # the script's plans, on the host: every core but the one that drives the device
        self.planner = PlannerPool(model, workers=max(1, (os.cpu_count() or 2) - 1))
        self.cube = model.body("cube").id
        self.num_envs, self.size, self.seed = num_envs, size, seed
        self.task_text = task.spec.summary
        self._chunk = jax.jit(self._rollout_chunk)
        self._success = jax.jit(lambda state, running: running & (self.env.metrics(state)["success"] > 0))
        self._plans_ahead = ThreadPoolExecutor(max_workers=1, thread_name_prefix="demos-plans")  # one batch ahead

    def rollouts(self) -> Iterator[Rollout]:
        import jax

        key = jax.random.PRNGKey(self.seed)
        key, draw = jax.random.split(key)
        state = self.env.reset(draw)
        plans = self._plans_ahead.submit(self._plan, state)
        status_line(
            f"demos: compiling the rollout of {self.num_envs} MuJoCo Warp environments on {self.device} "
            "(the first batch waits for it)"
        )
        while True:
            arm, jaw, live = plans.result()
            key, draw = jax.random.split(key)
            upcoming = self.env.reset(draw)  # queued before this batch's chunks: the planner reads it meanwhile
            plans = self._plans_ahead.submit(self._plan, upcoming)
            yield from self._batch(state, arm, jaw, live)
            state = upcoming

    def close(self) -> None:
        self.planner.close()  # first: the batch being planned stops at its running chunks
        self._plans_ahead.shutdown(wait=True, cancel_futures=True)

    def _plan(self, state: Any) -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.bool_]]:
        """The script's arm and jaw targets for every environment of the freshly reset `state`, laid out as the
        chunks read them: (chunks, chunk_rows, stride, N, 5), (chunks, chunk_rows, stride, N) and which steps are
        the attempt's (chunks, chunk_rows, stride); the steps past its end pad the last chunk."""
        qpos = np.asarray(state.data.qpos, dtype=np.float64)
        cubes = np.asarray(state.data.xpos[:, self.cube], dtype=np.float64)
        goals = np.asarray(state.commands["goal"], dtype=np.float64)
        padded = self.chunks * self.chunk_rows * self.stride
        arm = np.zeros((padded, self.num_envs, len(self.planner.qpos_addresses)), np.float32)
        jaw = np.zeros((padded, self.num_envs), np.float32)
        for i, plan in enumerate(self.planner.plans(qpos, cubes, goals)):
            arm[: plan.steps, i], jaw[: plan.steps, i] = plan.arm, plan.jaw
        live = np.arange(padded) < self.steps
        layout = (self.chunks, self.chunk_rows, self.stride)
        return arm.reshape(*layout, *arm.shape[1:]), jaw.reshape(*layout, self.num_envs), live.reshape(layout)

    def _batch(
        self, state: Any, arm: NDArray[np.float32], jaw: NDArray[np.float32], live: NDArray[np.bool_]
    ) -> Iterator[Rollout]:
        """Roll the batch out chunk by chunk, each chunk's rows pulled while the next runs, and yield its attempts."""
        import jax.numpy as jnp

        n, rows = self.num_envs, self.rows
        states = np.zeros((n, rows, len(self.qpos_addresses)))
        targets = np.zeros_like(states)
        frames = {camera: np.zeros((n, rows, self.size[1], self.size[0], 3), np.uint8) for camera in self.cameras}
        carry = (
            state,
            jnp.asarray(self.env.task.reset_ctrl(np, n), jnp.float32),  # the servo targets the script starts from
            jnp.zeros((n, arm.shape[-1]), jnp.float32),  # its sag correction
            jnp.ones(n, bool),  # no episode ended before the script did
        )

        def store(chunk: int, pulled: Any) -> None:
            first, count = chunk * self.chunk_rows, min(self.chunk_rows, rows - chunk * self.chunk_rows)
            qpos, commanded, images = pulled
            states[:, first : first + count] = np.swapaxes(np.asarray(qpos), 0, 1)[:, :count]
            targets[:, first : first + count] = np.swapaxes(np.asarray(commanded), 0, 1)[:, :count]
            for camera, kept in frames.items():
                kept[:, first : first + count] = np.swapaxes(np.asarray(images[camera]), 0, 1)[:, :count]

        pending = None
        for chunk in range(self.chunks):
            carry, pulled = self._chunk(carry, arm[chunk], jaw[chunk], live[chunk])
            if pending is not None:
                store(*pending)
            pending = chunk, pulled
        store(*pending)
        success = np.asarray(self._success(carry[0], carry[3]))
        for i in range(n):
            yield Rollout(
                states=states[i],
                actions=targets[i],
                frames={camera: kept[i] for camera, kept in frames.items()},
                success=bool(success[i]),
            )

    def _rollout_chunk(self, carry: Any, arm: Any, jaw: Any, live: Any) -> tuple[Any, Any]:
        """`chunk_rows` dataset rows of `stride` control steps each (a step whose `live` is false is skipped); per
        row the joint positions and frames before its first step and the servo targets commanded at it."""
        import jax
        import jax.numpy as jnp

        from joshua_mujoco import corrected_targets, integrate_sag

        env, task = self.env, self.env.task
        arm_addresses = jnp.asarray(self.planner.qpos_addresses)
        joints = jnp.asarray(self.qpos_addresses)

        def control(carry: Any, step: Any) -> tuple[Any, jax.Array]:
            arm, jaw, live = step

            def act(carry: Any) -> Any:
                state, in_force, sag, running = carry
                action = task.action_for_ctrl(jnp, corrected_targets(jnp, arm, jaw, sag), ctrl=in_force)
                in_force = task.action_to_ctrl(jnp, action, ctrl=in_force).astype(jnp.float32)
                state = env.step(state, action)
                sag = integrate_sag(jnp, sag, arm, state.data.qpos[:, arm_addresses]).astype(jnp.float32)
                return state, in_force, sag, running & ~(state.terminated | state.truncated)

            carry = jax.lax.cond(live, act, lambda carry: carry, carry)
            return carry, carry[1]

        def row(carry: Any, steps: Any) -> tuple[Any, Any]:
            state = carry[0]
            seen = state.data.qpos[:, joints], state.images
            carry, commanded = jax.lax.scan(control, carry, steps)
            return carry, (seen[0], commanded[0], seen[1])

        return jax.lax.scan(row, carry, (arm, jaw, live))


def with_cameras(
    task_config: TaskConfig | None, cameras: Sequence[str], size: tuple[int, int], every: int
) -> TaskConfig:
    """`task_config` (or an empty one) rendering exactly `cameras`, rgb at `size` (w, h), on every `every`-th step."""
    config = TaskConfig()
    if task_config is not None:
        config.CopyFrom(task_config)
    del config.cameras[:]
    for camera in cameras:
        config.cameras.add(camera=camera, width=size[0], height=size[1], every_steps=every)
    return config
