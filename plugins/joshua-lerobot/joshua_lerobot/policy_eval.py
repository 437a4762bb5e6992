"""`joshua eval POLICY_FOLDER` for LeRobot policies: a policy trained in LeRobot (on a `joshua demos` dataset)
rolled out in the JOSHUA task the demonstrations came from, so that demos -> train in LeRobot -> evaluate in JOSHUA
closes.

The policy runs where lerobot is installed (`--lerobot-python`, a child process: `policy_process.py`); here the
task is simulated on CPU MuJoCo in `--num-envs` randomized environments (the environments `joshua demos` uses),
each camera the policy takes is rendered at the size it was trained on, and every `1 / --fps` seconds (a dataset
frame) the policy gets what a `joshua demos` dataset row holds: `observation.state` (the joint angles in LeRobot's
units, `--units`) and `observation.images.<camera>`, and its `action` (joint targets in the same units) is held as
the servos' target until the next frame, as the demonstrations' targets were.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from joshua_core.cli import add_config_arguments, load
from joshua_core.config import finalize
from joshua_core.errors import UsageError
from joshua_core.interfaces import EpisodeResults, PolicyFormat
from joshua_core.json_files import read_json_object
from joshua_core.limits import MAX_FPS, MIN_FPS, cli_number
from joshua_core.progress import progress_bar
from joshua_core.run_context import RunContext
from joshua_lerobot.demos import DEFAULT_FPS, DEFAULT_NUM_ENVS, DEFAULT_PRESET, MAX_NUM_ENVS
from joshua_lerobot.joints import LeRobotUnits, add_units_arguments, feature_names, units_from_arguments
from joshua_lerobot.writer import ACTION, CAMERA_PREFIX, STATE

if TYPE_CHECKING:
    from tqdm import tqdm

    from joshua_lerobot.policy_process import PolicyDescription, PolicyProcess

POLICY_FILES = ("config.json", "model.safetensors")  # what LeRobot's save_pretrained writes for every policy
DEFAULT_REPLY_SECONDS = 300.0  # loading lerobot, torch and a policy on a busy CPU takes about a minute
MAX_REPLY_SECONDS = 86400.0


@dataclass(frozen=True)
class CameraInput:
    """A camera a policy takes: the model camera and the size (width, height) it is rendered at."""

    camera: str
    width: int
    height: int


@dataclass(frozen=True)
class Evaluation:
    """What the rollouts gave: each episode's outcome, and the last `observation.state` the policy was given in
    each episode (episodes, joints) in LeRobot's units: where the policy's actions took the arm."""

    results: EpisodeResults
    last_states: NDArray[np.float32]


class LeRobotPolicyFormat(PolicyFormat):
    """LeRobot pretrained-policy folders (`config.json` with the policy `type`, `model.safetensors`)."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        group = parser.add_argument_group("LeRobot policies (a folder save_pretrained wrote)")
        group.add_argument(
            "--lerobot-python",
            metavar="PATH",
            default=sys.executable,
            help="the Python with lerobot that loads and runs the policy (default: this one)",
        )
        group.add_argument(
            "--lerobot-device", default="cpu", help="torch device the policy runs on (default cpu; e.g. cuda)"
        )
        group.add_argument(
            "--lerobot-timeout",
            metavar="SECONDS",
            type=cli_number("--lerobot-timeout", 1, MAX_REPLY_SECONDS),
            default=DEFAULT_REPLY_SECONDS,
            help="the most a policy may take to load or to answer a batch; past it the policy process is stopped "
            f"(default {DEFAULT_REPLY_SECONDS:g})",
        )
        group.add_argument(
            "--lerobot-task", metavar="TEXT", help="the task text the policy is given (default: the task's own)"
        )
        group.add_argument(
            "--fps",
            type=cli_number("--fps", MIN_FPS, MAX_FPS, integer=True),
            default=DEFAULT_FPS,
            help=f"frames per second of the dataset the policy learnt from: one action each (default {DEFAULT_FPS})",
        )
        group.add_argument(
            "--num-envs",
            type=cli_number("--num-envs", 1, MAX_NUM_ENVS, integer=True),
            default=DEFAULT_NUM_ENVS,
            help=f"environments rolled out at once, one policy batch (default {DEFAULT_NUM_ENVS})",
        )
        add_units_arguments(parser, what="a LeRobot policy's")
        add_config_arguments(
            parser,
            verb=f"for a LeRobot policy, take the task and its randomization from (default --preset {DEFAULT_PRESET})",
        )

    def accepts(self, path: Path) -> bool:
        if not all((path / name).is_file() for name in POLICY_FILES):
            return False
        try:
            document = read_json_object(path / POLICY_FILES[0], "the policy's config")
        except UsageError:
            return False
        return isinstance(document.get("type"), str) and "trainer" not in document

    def evaluate(
        self,
        path: Path,
        args: argparse.Namespace,
        *,
        episodes: int,
        seed: int,
        video_path: Path | None,
        video_grid: int,
        context: RunContext,
    ) -> EpisodeResults:
        from joshua_lerobot.policy_process import PolicyProcess

        units = units_from_arguments(args)
        if not (args.preset or args.config):
            args.preset = DEFAULT_PRESET
        training = finalize(load(args, context.plugins.options())).training
        num_envs = min(args.num_envs, episodes)
        if video_grid > num_envs:
            raise UsageError(f"--grid {video_grid} tiles episodes of one batch: at most --num-envs ({num_envs})")
        with PolicyProcess(args.lerobot_python, path, args.lerobot_device, args.lerobot_timeout) as policy:
            return evaluate_policy(
                policy,
                training.task,
                episodes=episodes,
                num_envs=num_envs,
                seed=seed,
                fps=args.fps,
                units=units,
                context=context,
                task_config=training.task_config if training.HasField("task_config") else None,
                task_text=args.lerobot_task,
                video_path=video_path,
                video_grid=video_grid,
            ).results


def evaluate_policy(
    policy: PolicyProcess,
    task_name: str,
    *,
    episodes: int,
    num_envs: int,
    seed: int,
    fps: int,
    units: LeRobotUnits,
    context: RunContext,
    task_config: Any = None,
    task_text: str | None = None,
    video_path: Path | None = None,
    video_grid: int = 1,
) -> Evaluation:
    """Roll `policy` out for `episodes` episodes of the task `task_name` (its own scene, randomized by
    `task_config`), `num_envs` at a time from `seed`, one action every `1 / fps` seconds; state and actions in
    `units`. Features the task does not provide are a UsageError naming them, before any step. With
    `video_path`, the first `video_grid` episodes of the policy's first camera, tiled, as an MP4."""
    from joshua_lerobot.rollouts import frame_stride
    from joshua_mujoco import make_vector_env

    env = make_vector_env(task_name, num_envs, seed=seed, task_config=task_config, plugins=context.plugins)
    try:
        rollout = _Rollout(env, policy, fps, units, task_text)
        stride = frame_stride(env.simulation.task.dt, fps)
        video = None
        if video_path is not None:
            from joshua_render import GridVideoWriter

            video = GridVideoWriter(video_path, fps, video_grid)
        returns: list[float] = []
        lengths: list[float] = []
        metrics: dict[str, list[float]] = {}
        last_states = []
        total = episodes * env.simulation.task.spec.episode_length
        with progress_bar(total, description="eval", unit="env steps") as bar:  # closed before an error is printed
            while len(returns) < episodes:
                if returns:
                    env.reset()  # the next draws of the same random stream
                wanted = min(num_envs, episodes - len(returns))
                batch = rollout.batch(stride, video if not returns else None, bar, wanted)
                returns += batch.returns[:wanted].tolist()
                lengths += batch.lengths[:wanted].tolist()
                for name, values in batch.metrics.items():
                    metrics.setdefault(name, []).extend(values[:wanted].tolist())
                last_states.append(batch.last_states[:wanted])
        if video is not None:
            video.close()
    finally:
        env.close()
    return Evaluation(EpisodeResults(returns, lengths, metrics), np.concatenate(last_states))


@dataclass(frozen=True)
class _Batch:
    returns: NDArray[np.float64]
    lengths: NDArray[np.float64]
    metrics: dict[str, NDArray[np.float64]]
    last_states: NDArray[np.float32]


class _Rollout:
    """One vector environment and the policy: the joint and camera mapping between them, checked once."""

    def __init__(self, env: Any, policy: PolicyProcess, fps: int, units: LeRobotUnits, task_text: str | None):
        from joshua_lerobot.scripted_rollouts import actuated_joints

        model = env.simulation.model
        self.joint_names, self.ranges, self.qpos_addresses = actuated_joints(model)
        self.names, _ = feature_names(self.joint_names)
        cameras = [str(model.camera(i).name) for i in range(model.ncam)]
        self.inputs = check_features(policy.description, len(self.names), cameras)
        self.env, self.policy, self.fps, self.units = env, policy, fps, units
        self.task_text = task_text or env.simulation.task.spec.summary

    def state(self) -> NDArray[np.float32]:
        """(envs, joints) joint angles now, in LeRobot's units."""
        qpos = self.env.simulation.qpos[:, self.qpos_addresses]
        columns = [
            self.units.from_model(name, qpos[:, i], self.ranges[joint])
            for i, (name, joint) in enumerate(zip(self.names, self.joint_names, strict=True))
        ]
        return np.stack(columns, axis=1).astype(np.float32)

    def targets(self, actions: NDArray[np.float32]) -> NDArray[np.float64]:
        """(envs, joints) LeRobot actions as the model joints' targets."""
        columns = [
            self.units.to_model(name, actions[:, i].astype(np.float64), self.ranges[joint])
            for i, (name, joint) in enumerate(zip(self.names, self.joint_names, strict=True))
        ]
        return np.stack(columns, axis=1)

    def batch(self, stride: int, video: Any, bar: tqdm, wanted: int) -> _Batch:
        """Roll every environment's episode out from its reset; tiles of the first episodes go to `video`. `bar`
        (over the `wanted` episodes' steps) moves on every control step, since a batch of a CPU scene with cameras
        can take minutes; an episode that ends early counts its whole length once the batch ends."""
        from joshua_render import episode_label

        env, simulation = self.env, self.env.simulation
        task, n = simulation.task, env.num_envs
        self.policy.reset()
        start = bar.n
        running = np.ones(n, dtype=bool)
        returns, lengths = np.zeros(n), np.zeros(n)
        metrics: dict[str, NDArray[np.float64]] = {}
        last_states = np.zeros((n, len(self.names)), np.float32)
        step = 0
        while running.any():
            if step % stride == 0:
                state = self.state()
                last_states[running] = state[running]
                frames = {
                    key: np.stack([env.render_frame(i, camera.camera, camera.width, camera.height) for i in range(n)])
                    for key, camera in self.inputs.items()
                }
                targets = self.targets(self.policy.select_action(state, frames, [self.task_text] * n))
                if video is not None and frames:
                    shown = next(iter(frames.values()))
                    labels = [episode_label(i, returns[i]) for i in range(video.tiles)]
                    video.write([shown[i] if running[i] else None for i in range(video.tiles)], labels)
            actions = task.action_for_ctrl(np, targets, simulation.params, simulation.ctrl)
            _, reward, terminated, truncated, infos = env.step(actions)
            returns += np.where(running, reward, 0.0)
            lengths += running
            ended = running & (terminated | truncated)
            for name, values in infos["metrics"].items():
                metrics.setdefault(name, np.zeros(n))[ended] = np.asarray(values)[ended]
            running &= ~ended
            bar.update(int(running[:wanted].sum()))
            step += 1
        bar.update(start + wanted * task.spec.episode_length - bar.n)
        return _Batch(returns, lengths, metrics, last_states)


def check_features(description: PolicyDescription, joints: int, cameras: list[str]) -> dict[str, CameraInput]:
    """The cameras a policy takes (image key -> camera and size), after checking that its inputs and outputs are
    what a `joshua demos` dataset of this model has: `observation.state` and `action` of `joints` values, and
    `observation.images.<camera>` (3, H, W) of the model's `cameras`. Anything else is a UsageError naming it."""
    inputs, outputs = description.inputs, description.outputs
    provided = [STATE, *(CAMERA_PREFIX + camera for camera in cameras)]
    unknown = [key for key in inputs if key not in provided]
    if unknown:
        raise UsageError(
            f"the {description.type} policy takes {', '.join(unknown)}, which the task does not provide "
            f"(it provides {', '.join(provided)})"
        )
    problems = []
    if STATE in inputs and inputs[STATE].shape != (joints,):
        problems.append(f"{STATE} of shape {list(inputs[STATE].shape)} (the task's: [{joints}])")
    if ACTION not in outputs or outputs[ACTION].shape != (joints,):
        shape = list(outputs[ACTION].shape) if ACTION in outputs else "none"
        problems.append(f"{ACTION} of shape {shape} (the task's joint targets: [{joints}])")
    inputs_by_camera = {}
    for key, feature in inputs.items():
        if key == STATE:
            continue
        if len(feature.shape) != 3 or feature.shape[0] != 3:
            problems.append(f"{key} of shape {list(feature.shape)} (RGB images: [3, height, width])")
            continue
        inputs_by_camera[key] = CameraInput(key.removeprefix(CAMERA_PREFIX), feature.shape[2], feature.shape[1])
    if problems:
        raise UsageError(f"the {description.type} policy does not fit the task: it has {'; '.join(problems)}")
    return inputs_by_camera
