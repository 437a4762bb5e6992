"""Recordings for system identification, checked against the model: what each position actuator was told
(`<joint>.target` columns) and where its joint went, on a time axis starting at 0.

They are read by `joshua_core.trajectory.read_trajectory`, the reader every replay uses; this module adds
only what a fit needs besides: commanded targets, finite values, enough samples, a column for every
actuated joint, values plausible for the model's joint ranges, some motion, and a model whose actuators are all
position servos.
"""

from __future__ import annotations

import difflib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import numpy as np
from numpy.typing import NDArray

from joshua_core.errors import ModelError, UsageError
from joshua_core.resources import resolve_data_path
from joshua_core.trajectory import TARGET_SUFFIX
from joshua_core.trajectory_sources import load_trajectory
from joshua_modes import model_joint_ranges

if TYPE_CHECKING:
    from joshua_core.plugins import PluginHost

MIN_SAMPLES = 20  # fewer samples than this cannot tell four parameters per joint apart
MIN_DURATION_S = 1.0  # nor can a recording shorter than a few servo time constants
MIN_MOTION = 1e-4  # rad or m: below a tenth of one step of a 12-bit servo encoder (2 pi / 4096), no motion at all
# The fit simulates each recording from its first row with zero velocity, so the arm must be at rest there: between
# the first two rows no joint's speed may exceed REST_SPEED (rad/s or m/s), four encoder steps (2 pi / 4096
# each) per frame at 30 fps, which encoder noise does not reach and an arm in motion does.
REST_SPEED = 0.2
SCALAR_JOINTS = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


@dataclass(frozen=True)
class Servo:
    """A position actuator and the joint it drives."""

    actuator: str
    joint: str


@dataclass(frozen=True)
class Recording:
    """One recording, columns in the order of the model's servos; `times` start at 0."""

    path: Path
    times: NDArray[np.float64]  # (rows,)
    positions: NDArray[np.float64]  # (rows, servos) measured joint positions
    targets: NDArray[np.float64]  # (rows, servos) commanded positions (the actuators' ctrl)


def model_servos(model: mujoco.MjModel, model_path: Path) -> list[Servo]:
    """The model's actuators, each a position actuator on a hinge or slide joint (else a ModelError)."""
    if model.nu == 0:
        raise ModelError(f"{model_path}: the model has no actuators; joshua sysid fits position actuators")
    servos = []
    for index in range(model.nu):
        actuator = model.actuator(index)
        joint = int(model.actuator_trnid[index, 0])
        is_position = (
            model.actuator_trntype[index] == mujoco.mjtTrn.mjTRN_JOINT
            and model.jnt_type[joint] in SCALAR_JOINTS
            and model.actuator_gaintype[index] == mujoco.mjtGain.mjGAIN_FIXED
            and model.actuator_biastype[index] == mujoco.mjtBias.mjBIAS_AFFINE
            and model.actuator_dyntype[index] == mujoco.mjtDyn.mjDYN_NONE
            and actuator.gainprm[0] > 0
            and actuator.gainprm[0] == -actuator.biasprm[1]
        )
        if not is_position:
            raise ModelError(
                f"{model_path}: actuator '{actuator.name or index}' is not a position actuator on a hinge or slide "
                "joint (gain kp, bias -kp); joshua sysid fits models whose actuators all are"
            )
        if not actuator.name:
            raise ModelError(f"{model_path}: actuator {index} has no name; name it to fit its gain")
        servos.append(Servo(actuator.name, model.joint(joint).name))
    return servos


def load_recordings(
    paths: Sequence[Path], model: mujoco.MjModel, servos: list[Servo], plugins: PluginHost, *, episode: int = 0
) -> list[Recording]:
    """Read and check each recording (a UsageError names the file and what is wrong); dataset folders are read by
    the trajectory readers of `plugins`, episode `episode` of each."""
    joints = model_joint_ranges(model)
    return [
        _load(resolve_data_path(path, what="recording", folders=True), joints, servos, plugins, episode)
        for path in paths
    ]


def _load(
    path: Path, model_joints: dict[str, tuple[float, float]], servos: list[Servo], plugins: PluginHost, episode: int
) -> Recording:
    """One recording: a trajectory CSV or a dataset folder (e.g. LeRobot's, through its trajectory reader)."""
    trajectory = load_trajectory(path, model_joints, episode=episode, plugins=plugins)
    if trajectory.targets is None:
        raise UsageError(
            f"{path}: no commanded targets; joshua sysid needs a '<joint>{TARGET_SUFFIX}' column beside each joint "
            "column (the position sent to its actuator)"
        )
    untargeted = [name for i, name in enumerate(trajectory.joint_names) if np.isnan(trajectory.targets[:, i]).all()]
    if untargeted:
        raise UsageError(
            f"{path}: no commanded targets for {', '.join(untargeted)}; every fitted joint needs its target"
        )
    trajectory.require_playable()
    duration = trajectory.timestamps[-1] - trajectory.timestamps[0]
    if trajectory.rows < MIN_SAMPLES or duration < MIN_DURATION_S:
        raise UsageError(
            f"{path}: too short to fit: {trajectory.rows} samples over {duration:g} s; record at least "
            f"{MIN_SAMPLES} samples and {MIN_DURATION_S:g} s of varied motion"
        )
    missing = [servo.joint for servo in servos if servo.joint not in trajectory.joint_names]
    if missing:
        raise UsageError(
            f"{path}: no column for the actuated joints {', '.join(missing)}; every actuator needs its target; "
            f"columns: {', '.join(trajectory.joint_names)}"
        )
    unactuated = [name for name in trajectory.joint_names if name not in {servo.joint for servo in servos}]
    if unactuated:
        close = difflib.get_close_matches(unactuated[0], [servo.joint for servo in servos], n=1)
        hint = f" (did you mean {close[0]}?)" if close else ""
        raise UsageError(f"{path}: joint '{unactuated[0]}'{hint} has no position actuator in the model to fit")
    columns = [trajectory.joint_names.index(servo.joint) for servo in servos]
    positions, targets = trajectory.positions[:, columns], trajectory.targets[:, columns]
    for index, servo in enumerate(servos):
        for what, values in (("position", positions[:, index]), ("target", targets[:, index])):
            _check_plausible(path, servo.joint, what, values, model_joints[servo.joint])
    _check_starts_at_rest(path, trajectory.joint_names, trajectory.timestamps, trajectory.positions)
    if (np.ptp(positions, axis=0) < MIN_MOTION).all():
        raise UsageError(
            f"{path}: no joint moves (each spans less than {MIN_MOTION:g} rad or m), so it tells the fit nothing; "
            "record the servos following varied targets"
        )
    return Recording(path, trajectory.timestamps - trajectory.timestamps[0], positions, targets)


def _check_plausible(
    path: Path, joint: str, what: str, values: NDArray[np.float64], joint_range: tuple[float, float]
) -> None:
    """A limited joint's recorded values lie within its range widened by the range's width on each side: further
    out, the recording is of another robot or in other units (degrees, encoder steps), and fitting it is wrong."""
    low, high = joint_range
    if not (np.isfinite(low) and np.isfinite(high)) or np.isnan(values).all():
        return
    width = high - low
    worst = float(values[np.nanargmax(np.abs(values - (low + high) / 2))])
    if not low - width <= worst <= high + width:
        raise UsageError(
            f"{path}: joint '{joint}' has a {what} of {worst:g}, far outside its range [{low:g}, {high:g}]: not a "
            "plausible value for this model; is the recording of this robot, in radians or metres?"
        )


def _check_starts_at_rest(
    path: Path, joints: Sequence[str], times: NDArray[np.float64], positions: NDArray[np.float64]
) -> None:
    """No joint's speed exceeds REST_SPEED between the first two rows (the fit starts the recording at rest)."""
    speeds = np.abs(positions[1] - positions[0]) / (times[1] - times[0])
    fastest = int(np.argmax(speeds))
    if speeds[fastest] > REST_SPEED:
        raise UsageError(
            f"{path}: does not start at rest: joint '{joints[fastest]}' moves at {speeds[fastest]:.3g}/s between its "
            f"first two rows (at most {REST_SPEED:g}); the fit starts each recording from its first row with zero "
            "velocity, so record from a standstill"
        )
