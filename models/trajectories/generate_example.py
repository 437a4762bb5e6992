"""Generate ``so_arm100_example.csv``: a reach-and-grasp joint trajectory for the SO-ARM100.

The motion picks up the cube of ``so_arm100/pick_place.xml``: home -> above the cube -> down
-> close the jaw -> lift -> back towards home, cube held.  Waypoints are solved with damped
least-squares inverse kinematics on the MuJoCo model (gripper pointing straight down, pads
facing the cube's x faces) and joined by minimum-jerk segments in joint space, sampled at
500 Hz.  The joint limits are read from ``so_arm100.xml`` and every sample is asserted to lie
strictly inside them.

Usage::

    python models/trajectories/generate_example.py [OUTPUT_CSV]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import mujoco
import numpy as np

MODELS = Path(__file__).resolve().parents[1]
ARM_XML = MODELS / "so_arm100" / "so_arm100.xml"
TASK_XML = MODELS / "so_arm100" / "pick_place.xml"
DEFAULT_CSV = Path(__file__).resolve().parent / "so_arm100_example.csv"

JOINTS = [f"joint_{i}" for i in range(1, 7)]
DT = 0.002  # 500 Hz
HOLD_START = 0.4  # s at home before moving
CUBE_HALF = 0.015
GRASP_HEIGHT = 0.022  # gripper site (pad centre) height: fingertips stay 3 mm above the table
APPROACH_CLEARANCE = 0.07  # pre-grasp height above the grasp pose
LIFT_HEIGHT = 0.08
PAD_STANDOFF = 0.004  # fixed pad clearance from the cube face while descending
JAW_OPEN = 0.9  # rad, ~5 cm between the pads
JAW_SQUEEZE = 0.15  # rad, commanded past contact so the servo squeezes the cube


def min_jerk(s: np.ndarray) -> np.ndarray:
    """Minimum-jerk time scaling 10 s^3 - 15 s^4 + 6 s^5 on s in [0, 1]."""
    return s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


def solve_ik(model: mujoco.MjModel, target: np.ndarray, pad_normal: np.ndarray, q_init: np.ndarray) -> np.ndarray:
    """Arm joints (joint_1..5) putting the ``gripper`` site at ``target``, pointing down, pads along ``pad_normal``."""
    data = mujoco.MjData(model)
    site = model.site("gripper").id
    dofs = [model.joint(name).dofadr[0] for name in JOINTS[:5]]
    qadr = [model.joint(name).qposadr[0] for name in JOINTS[:5]]
    lo, hi = model.jnt_range[[model.joint(name).id for name in JOINTS[:5]]].T
    x_goal, z_goal = np.array([0.0, 0.0, -1.0]), pad_normal / np.linalg.norm(pad_normal)
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    q = q_init.copy()
    for _ in range(500):
        data.qpos[qadr] = q
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        rot = data.site_xmat[site].reshape(3, 3)
        err = np.concatenate(
            [target - data.site_xpos[site], 0.5 * (np.cross(rot[:, 0], x_goal) + np.cross(rot[:, 2], z_goal))]
        )
        if np.linalg.norm(err) < 1e-7:
            break
        mujoco.mj_jacSite(model, data, jacp, jacr, site)
        jac = np.vstack([jacp[:, dofs], jacr[:, dofs]])
        step = jac.T @ np.linalg.solve(jac @ jac.T + 1e-6 * np.eye(6), err)
        q = np.clip(q + step, lo + 1e-3, hi - 1e-3)
    assert np.linalg.norm(err) < 1e-5, f"IK did not converge for {target}: residual {np.linalg.norm(err):.2e}"
    return q


def build_trajectory() -> tuple[np.ndarray, np.ndarray]:
    """Return (timestamps, joint targets of shape (n, 6)) of the reach-and-grasp motion."""
    task = mujoco.MjModel.from_xml_path(str(TASK_XML))
    cube = task.body("cube").pos.copy()
    home = task.key("home").ctrl.copy()

    pad_normal = np.array([1.0, 0.0, 0.0])  # the fixed pad presses on the cube's -x face
    grasp = cube + np.array([-CUBE_HALF, 0.0, 0.0])
    grasp[2] = GRASP_HEIGHT
    descend = grasp - PAD_STANDOFF * pad_normal

    def arm(target: np.ndarray, q_init: np.ndarray) -> np.ndarray:
        return solve_ik(task, target, pad_normal, q_init)

    q_above = arm(descend + [0.0, 0.0, APPROACH_CLEARANCE], home[:5])
    q_down = arm(descend, q_above)
    q_lift = arm(grasp + [0.0, 0.0, LIFT_HEIGHT], q_down)

    # Segments after the initial hold: (duration [s], pose reached at its end).
    segments = [
        (1.4, np.append(q_above, JAW_OPEN)),
        (0.8, np.append(q_down, JAW_OPEN)),
        (0.6, np.append(q_down, JAW_SQUEEZE)),
        (0.3, np.append(q_down, JAW_SQUEEZE)),
        (1.0, np.append(q_lift, JAW_SQUEEZE)),
        (1.2, np.append(home[:5], JAW_SQUEEZE)),
        (0.4, np.append(home[:5], JAW_SQUEEZE)),
    ]
    samples = [np.repeat(home[None, :], 1 + round(HOLD_START / DT), axis=0)]
    for duration, end in segments:
        start = samples[-1][-1]
        s = np.arange(1, round(duration / DT) + 1) * DT / duration
        samples.append(start + min_jerk(s)[:, None] * (end - start))
    positions = np.vstack(samples)
    times = np.arange(len(positions)) * DT
    return times, positions


def check_limits(positions: np.ndarray) -> None:
    """Assert every sample lies strictly inside the joint ranges of so_arm100.xml."""
    arm = mujoco.MjModel.from_xml_path(str(ARM_XML))
    lo, hi = arm.jnt_range[[arm.joint(name).id for name in JOINTS]].T
    assert np.all(positions > lo) and np.all(positions < hi), "trajectory leaves the joint limits"


def write_csv(path: Path, times: np.ndarray, positions: np.ndarray) -> None:
    """Write the trajectory with its comment header."""
    lines = [
        "# SO-ARM100 example trajectory: reach and grasp the pick_place.xml cube, lift it, return",
        "# towards home.  Minimum-jerk segments between IK waypoints; position targets for the",
        "# joint_N_position actuators (generated by generate_example.py).",
        "# Format: timestamp, joint_1, joint_2, joint_3, joint_4, joint_5, joint_6",
        "# Units: seconds, radians (joint_6 is the jaw angle, 0 = nearly closed, positive opens)",
        "timestamp," + ",".join(JOINTS),
    ]
    lines += [f"{t:.3f}," + ",".join(f"{v:.6f}" for v in q) for t, q in zip(times, positions, strict=True)]
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output", nargs="?", type=Path, default=DEFAULT_CSV)
    args = parser.parse_args()
    times, positions = build_trajectory()
    check_limits(positions)
    write_csv(args.output, times, positions)
    print(f"{args.output}: {len(times)} samples, {times[-1]:.3f} s")


if __name__ == "__main__":
    main()
