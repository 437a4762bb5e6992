"""Body mass properties: MassAPI mass, centerOfMass, diagonalInertia and principalAxes where authored, the
rest from the colliders' densities as MuJoCo computes them (a first compile of the spec)."""

from __future__ import annotations

import mujoco
import numpy as np
from pxr import Usd, UsdPhysics

from joshua_usd.importer.pose import Vec
from joshua_usd.importer.report import ImportReport
from joshua_usd.importer.stage import StageFrame, positive, read, read_array, read_authored, read_quat

# What a body with no mass and no colliders gets (as PhysX does, with a warning): 1 kg, a 10 cm solid sphere.
FALLBACK_MASS = 1.0
FALLBACK_RADIUS = 0.1
NEGLIGIBLE_MASS = 1e-9


def probe(spec: mujoco.MjSpec, report: ImportReport) -> mujoco.MjModel:
    """Compile a copy of `spec` that tolerates massless bodies, for the geometric mass properties and qpos0."""
    trial = spec.copy()
    trial.compiler.boundmass = NEGLIGIBLE_MASS
    trial.compiler.boundinertia = NEGLIGIBLE_MASS
    return compile_spec(trial, report)


def compile_spec(spec: mujoco.MjSpec, report: ImportReport) -> mujoco.MjModel:
    """Compile `spec`, turning MuJoCo's (multi-line) error into a one-line ModelError naming the file."""
    try:
        return spec.compile()
    except ValueError as error:
        raise report.error("/", "model", f"does not compile in MuJoCo: {' '.join(str(error).split())}") from None


def set_inertial(
    body: mujoco.MjsBody, prim: Usd.Prim, scale: Vec, model: mujoco.MjModel, frame: StageFrame, report: ImportReport
) -> None:
    """Give `body` explicit mass properties where MassAPI authors any, or where it has no collider mass; a body
    with neither keeps what MuJoCo computes from its colliders."""
    index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body.name)
    geometric = float(model.body_mass[index])
    empty = geometric <= 10 * NEGLIGIBLE_MASS
    authored = prim.HasAPI(UsdPhysics.MassAPI)
    if not authored and not empty:
        return
    authored_mass = read(prim, "physics:mass", report) or 0.0  # 0 (the default) means "from density"
    mass = positive(prim, "physics:mass", authored_mass, report) * frame.kilograms_per_unit
    full = _full_inertia(prim, report)
    diagonal = np.zeros(3) if full is not None else read(prim, "physics:diagonalInertia", report)
    diagonal = np.asarray(diagonal if diagonal is not None else np.zeros(3), dtype=np.float64)
    for value in diagonal:
        positive(prim, "physics:diagonalInertia", value, report)
    center = read(prim, "physics:centerOfMass", report, allow_inf=True)
    if empty and (not mass or (full is None and not diagonal.any())):
        report.warn(
            prim.GetPath(), "no collider to weigh: its mass is 1 kg unless authored, its inertia a 10 cm sphere's"
        )
    mass = mass or (FALLBACK_MASS if empty else geometric)
    body.explicitinertial = True
    body.mass = mass
    if full is not None:
        body.fullinertia = full * frame.kilograms_per_unit * frame.meters_per_unit**2
    elif diagonal.any():
        body.inertia = diagonal * frame.kilograms_per_unit * frame.meters_per_unit**2
        axes = read_quat(prim, "physics:principalAxes", report)
        body.iquat = axes if axes is not None else [1.0, 0, 0, 0]
    elif empty:
        body.inertia = [0.4 * mass * FALLBACK_RADIUS**2] * 3
    else:
        body.inertia = model.body_inertia[index] * mass / geometric
        body.iquat = model.body_iquat[index]
    if center is not None and np.isfinite(np.asarray(center)).all():
        body.ipos = scale * np.asarray(center, dtype=np.float64)
    else:
        body.ipos = model.body_ipos[index]


def _full_inertia(prim: Usd.Prim, report: ImportReport) -> np.ndarray | None:
    """NewtonMassAPI's newton:inertia, [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] in the body frame, which overrides
    diagonalInertia and principalAxes; None when unauthored or empty (no opinion)."""
    value = read_authored(prim, "newton:inertia", report)
    if value is None or not len(value):
        return None
    full = read_array(prim, "newton:inertia", 6, report)
    assert full is not None  # authored and not empty
    for moment in full[:3]:
        positive(prim, "newton:inertia", float(moment), report)
    return full
