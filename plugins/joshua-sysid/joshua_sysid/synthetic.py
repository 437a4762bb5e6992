"""Recordings made in simulation, for trying `joshua sysid` without a robot and for testing it: a model whose
parameters are known follows multi-sine targets, and its joint positions are written with the targets as a
trajectory CSV with `<joint>.target` columns.

The simulation is the one the fit assumes: start at rest at the model's first keyframe (or qpos0), ctrl the
targets linearly interpolated at every physics step, positions sampled at the recording's timestamps.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import mujoco.rollout
import numpy as np
from numpy.typing import NDArray

from joshua_core.atomic import atomic_write_bytes
from joshua_core.trajectory import TARGET_SUFFIX, TIME_COLUMN
from joshua_sysid.recordings import Servo

SINES = 5  # per servo, with random frequencies and phases: rich excitation, no resonance hunting
FREQUENCY_RANGE_HZ = (0.2, 3.0)
AMPLITUDE = 0.6  # of the distance from the start to the nearer end of the servo's control range


def multisine_targets(
    model: mujoco.MjModel, start: NDArray[np.float64], times: NDArray[np.float64], seed: int
) -> NDArray[np.float64]:
    """(samples, nu) targets: per actuator a sum of sines about its start, inside its control range."""
    rng = np.random.default_rng(seed)
    low, high = model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1]
    room = np.minimum(high - start, start - low)
    targets = np.empty((len(times), model.nu))
    for actuator in range(model.nu):
        frequencies = rng.uniform(*FREQUENCY_RANGE_HZ, SINES)
        phases = rng.uniform(0, 2 * np.pi, SINES)
        wave = np.sin(2 * np.pi * frequencies[None, :] * times[:, None] + phases[None, :]).sum(axis=1) / SINES
        ramp = np.minimum(times / 0.5, 1.0)  # leave the rest pose smoothly
        targets[:, actuator] = start[actuator] + AMPLITUDE * room[actuator] * ramp * wave
    return targets


def simulate(
    model: mujoco.MjModel, servos: list[Servo], seed: int, duration: float, rate_hz: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Times, joint positions (samples, servos) and targets (samples, servos) of one simulated recording."""
    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    data.qvel[:] = 0
    actuators = [model.actuator(servo.actuator).id for servo in servos]
    addresses = [model.jnt_qposadr[model.joint(servo.joint).id] for servo in servos]
    first_qpos = data.qpos.copy()
    start = first_qpos[[model.jnt_qposadr[model.actuator_trnid[a, 0]] for a in range(model.nu)]]
    times = np.arange(0.0, duration + 0.5 / rate_hz, 1.0 / rate_hz)
    targets = multisine_targets(model, start, times, seed)
    steps = np.arange(0.0, times[-1] + model.opt.timestep / 2, model.opt.timestep)
    ctrl = np.stack([np.interp(steps, times, targets[:, a]) for a in range(model.nu)], axis=1)
    state_size = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    initial = np.empty(state_size)
    mujoco.mj_getState(model, data, initial, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    states, _ = mujoco.rollout.rollout(model, data, initial, ctrl[:-1])
    qpos = np.vstack([first_qpos[None, :], states[0][:, 1 : 1 + model.nq]])  # states[k]: after step k
    sampled = qpos[np.round(times / model.opt.timestep).astype(int)]
    return times, sampled[:, addresses], targets[:, actuators]


def write_csv(
    path: Path,
    servos: list[Servo],
    times: NDArray[np.float64],
    positions: NDArray[np.float64],
    targets: NDArray[np.float64],
) -> None:
    """A trajectory CSV: timestamp, the joints, then a `<joint>.target` column per joint."""
    joints = [servo.joint for servo in servos]
    header = ",".join([TIME_COLUMN, *joints, *(joint + TARGET_SUFFIX for joint in joints)])
    table = np.column_stack([times, positions, targets])
    lines = ["# simulated by joshua_sysid.synthetic: positions in rad (m for slide joints), targets sent to the servos"]
    lines += [header, *(",".join(f"{value:.9f}" for value in row) for row in table)]
    atomic_write_bytes(path, ("\n".join(lines) + "\n").encode())
