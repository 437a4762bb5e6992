"""How long `joshua sysid` takes to calibrate the SO-ARM100's 24 servo parameters (kp, damping, armature,
friction loss of 6 servos), against the cost of one simulation of the same recordings, measured in one run.

Recordings are simulated from a perturbed arm (kp x1.3, damping x0.7, armature x1.5, friction loss +0.05), as in
plugins/joshua-sysid/tests/test_sysid.py; the fit starts from the nominal model. The reference is one residual
evaluation (every recording simulated once); a finite-difference iteration costs about 25 of them (24 parameters
+ 1), so fit / reference says how many such simulations the fit needed.
Usage: python bench/sysid_fit.py [--recordings N] [--seconds S]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import mujoco
import numpy as np
from mujoco import sysid

from joshua_core.resources import models_dir
from joshua_sysid import fit, recordings, synthetic

ARM = models_dir() / "so_arm100" / "so_arm100.xml"
RATE_HZ = 100.0


def perturbed(spec: mujoco.MjSpec, servos: list[recordings.Servo]) -> mujoco.MjModel:
    true = spec.copy()
    for servo in servos:
        for kind, factor in (("kp", 1.3), ("damping", 0.7), ("armature", 1.5)):
            fit.write_value(true, servo, kind, fit.read_value(true, servo, kind) * factor)
        fit.write_value(true, servo, "frictionloss", fit.read_value(true, servo, "frictionloss") + 0.05)
    return true.compile()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recordings", type=int, default=2)
    parser.add_argument("--seconds", type=float, default=3.0, help="length of each recording")
    args = parser.parse_args()
    spec = mujoco.MjSpec.from_file(str(ARM))
    servos = recordings.model_servos(spec.copy().compile(), ARM)
    true = perturbed(spec, servos)
    loaded = []
    for seed in range(args.recordings):
        times, positions, targets = synthetic.simulate(true, servos, seed, args.seconds, RATE_HZ)
        loaded.append(recordings.Recording(Path(f"seed_{seed}"), times, positions, targets))
    residual = sysid.build_residual_fn(models_sequences=[fit.model_sequences(spec.copy(), servos, loaded)])
    parameters, _ = fit.build_parameters(spec, servos, fit.KINDS)
    evaluations = []
    for _ in range(5):
        start = time.perf_counter()
        residual(parameters.as_vector(), parameters)
        evaluations.append(time.perf_counter() - start)
    reference = min(evaluations)
    result = fit.fit(spec, servos, loaded, fit.KINDS, max_iters=50)
    worst = max(
        abs(result.identified[j][k] / v - 1) for j, kinds in _truth(true, servos).items() for k, v in kinds.items()
    )
    print(
        f"{args.recordings} recordings x {args.seconds:g} s at {RATE_HZ:g} Hz, "
        f"{len(servos) * len(fit.KINDS)} parameters"
    )
    print(f"one simulation of every recording (reference): {reference * 1e3:.1f} ms")
    print(
        f"fit: {result.seconds:.1f} s, {result.iterations} iterations, "
        f"{result.seconds / result.iterations:.2f} s/iteration"
    )
    print(f"fit / reference: {result.seconds / reference:.0f} simulations")
    print(
        f"tracking RMS {np.sqrt(np.mean(result.rms_before**2)):.2e} -> "
        f"{np.sqrt(np.mean(result.rms_after**2)):.2e} rad; "
        f"worst parameter error {worst * 100:.3f} %"
    )


def _truth(true: mujoco.MjModel, servos: list[recordings.Servo]) -> dict[str, dict[str, float]]:
    """The perturbed model's values, read back from the compiled model."""
    values = {}
    for servo in servos:
        dof = true.joint(servo.joint).dofadr[0]
        values[servo.joint] = {
            "kp": float(true.actuator(servo.actuator).gainprm[0]),
            "damping": float(true.dof_damping[dof]),
            "armature": float(true.dof_armature[dof]),
            "frictionloss": float(true.dof_frictionloss[dof]),
        }
    return values


if __name__ == "__main__":
    main()
