"""The fit: per servo, position gain kp (gainprm[0] and biasprm[1] = -kp together), joint damping, armature and
friction loss, found by mujoco.sysid's least squares on the recorded joint positions.

Each recording is simulated from its first measured pose at rest, with the actuators' ctrl the recorded
targets linearly interpolated at every physics step; the residual is measured minus simulated joint
position at the recording's own samples. Each parameter is fitted as a factor of its nominal value (or of
a floor when the nominal is 0), so that kp ~ 20 and armature ~ 0.03 are equally well scaled for the
optimizer.
"""

from __future__ import annotations

import io
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from absl import logging as absl_logging
from mujoco import sysid
from numpy.typing import NDArray

from joshua_core.progress import progress_bar
from joshua_sysid.recordings import Recording, Servo

KINDS = ("kp", "damping", "armature", "frictionloss")
# Search range of each parameter, as factors of its nominal value: wide enough for a model that is off by
# several times, narrow enough that the optimizer's first steps cannot throw a servo into a far, flat region.
FACTOR_BOUNDS = (0.2, 5.0)
# Scale of a parameter whose nominal value is 0 (the range is then [0, 5 x floor]).
FLOORS = {"kp": 1.0, "damping": 0.05, "armature": 0.005, "frictionloss": 0.01}
# A fitted factor this close (relative) to an end of its search range ended there: the optimizer would have gone
# further, so the arm's value may lie beyond the range and the other parameters bent to make up for it.
BOUND_TOLERANCE = 0.01
# A servo still missing its recordings by more than this share of its recorded motion (RMS about its mean) after
# the fit is not explained by the calibrated model (a parameter not fitted, or something the model lacks).
POOR_TRACKING_SHARE = 0.1


@dataclass(frozen=True)
class FitResult:
    """Nominal and identified values per servo and kind, tracking errors before and after, and cost."""

    nominal: dict[str, dict[str, float]]  # joint -> kind -> value
    identified: dict[str, dict[str, float]]
    rms_before: NDArray[np.float64]  # (servos,) rad or m
    rms_after: NDArray[np.float64]
    simulated_before: list[NDArray[np.float64]]  # per recording (samples, servos), at `sample_times`
    simulated_after: list[NDArray[np.float64]]
    sample_times: list[NDArray[np.float64]]
    measured: list[NDArray[np.float64]]
    iterations: int
    seconds: float


def read_value(spec: mujoco.MjSpec, servo: Servo, kind: str) -> float:
    """The current value of one parameter in `spec`."""
    if kind == "kp":
        return float(spec.actuator(servo.actuator).gainprm[0])
    joint = spec.joint(servo.joint)
    return float(joint.damping[0] if kind == "damping" else getattr(joint, kind))


def write_value(spec: mujoco.MjSpec, servo: Servo, kind: str, value: float) -> None:
    """Set one parameter in `spec`; kp goes to the gain and, negated, to the bias, so the servo stays a servo."""
    if kind == "kp":
        actuator = spec.actuator(servo.actuator)
        actuator.gainprm[0] = value
        actuator.biasprm[1] = -value
    elif kind == "damping":
        spec.joint(servo.joint).damping[0] = value
    else:
        setattr(spec.joint(servo.joint), kind, value)


def build_parameters(
    spec: mujoco.MjSpec, servos: list[Servo], kinds: Sequence[str]
) -> tuple[sysid.ParameterDict, dict[str, float]]:
    """One sysid Parameter `<joint>.<kind>` per servo and kind, a factor of its scale (the nominal value, or
    the floor), within bounds; and the scales by parameter name."""
    parameters = sysid.ParameterDict()
    scales = {}
    for servo in servos:
        for kind in kinds:
            name = f"{servo.joint}.{kind}"
            nominal = read_value(spec, servo, kind)
            scales[name] = nominal if nominal > 0 else FLOORS[kind]
            low, high = FACTOR_BOUNDS if nominal > 0 else (0.0, FACTOR_BOUNDS[1])
            modifier = _modifier(servo, kind, scales[name])
            parameters.add(sysid.Parameter(name, nominal / scales[name], low, high, modifier=modifier))
    return parameters, scales


def _modifier(servo: Servo, kind: str, scale: float) -> Callable[[mujoco.MjSpec, sysid.Parameter], None]:
    def apply(spec: mujoco.MjSpec, parameter: sysid.Parameter) -> None:
        write_value(spec, servo, kind, float(parameter.value[0]) * scale)

    return apply


def values_of(parameters: sysid.ParameterDict, scales: dict[str, float]) -> dict[str, dict[str, float]]:
    """{joint: {kind: value}} in the model's units."""
    values: dict[str, dict[str, float]] = {}
    for name, parameter in parameters.items():
        joint, kind = name.rsplit(".", 1)
        values.setdefault(joint, {})[kind] = float(parameter.value[0]) * scales[name]
    return values


def model_sequences(spec: mujoco.MjSpec, servos: list[Servo], recordings: list[Recording]) -> sysid.ModelSequences:
    """The recordings as mujoco.sysid sequences: ctrl on the physics step grid, measured joint positions."""
    absl_logging.set_verbosity(absl_logging.ERROR)  # sysid warns that joint positions are not all the sensors
    model = spec.compile()
    timestep = model.opt.timestep
    signals = [(f"{servo.joint}_qpos", sysid.SignalType.MjStateQPos) for servo in servos]
    addresses = [model.jnt_qposadr[model.joint(servo.joint).id] for servo in servos]
    controls, measured, starts = [], [], []
    actuator_order = [model.actuator(servo.actuator).id for servo in servos]
    for recording in recordings:
        steps = np.arange(0.0, recording.times[-1] + timestep / 2, timestep)
        ctrl = np.empty((len(steps), model.nu))
        for column, actuator in enumerate(actuator_order):
            ctrl[:, actuator] = np.interp(steps, recording.times, recording.targets[:, column])
        controls.append(sysid.TimeSeries(steps, ctrl))
        measured.append(sysid.TimeSeries.from_names(recording.times, recording.positions, model, names=signals))
        qpos = model.qpos0.copy()
        qpos[addresses] = recording.positions[0]
        starts.append(sysid.create_initial_state(model, qpos, np.zeros(model.nv)))
    names = [str(recording.path) for recording in recordings]
    return sysid.ModelSequences("recordings", spec, names, starts, controls, measured, allow_missing_sensors=True)


def fit(
    spec: mujoco.MjSpec,
    servos: list[Servo],
    recordings: list[Recording],
    kinds: Sequence[str],
    max_iters: int,
) -> FitResult:
    """Fit `kinds` of every servo to the recordings (`spec` is left as it is)."""
    sequences = model_sequences(spec.copy(), servos, recordings)  # sysid rewrites this spec at every evaluation
    residual = sysid.build_residual_fn(models_sequences=[sequences])
    nominal, scales = build_parameters(spec, servos, kinds)
    before = _simulate(residual, nominal)
    started = time.monotonic()
    logs: list[object] = []  # the optimizer's trace: one log per iteration, then one for the final point

    def advance(trace: list[object]) -> None:
        logs[:] = trace
        bar.update(min(len(trace), max_iters) - bar.n)

    with progress_bar(max_iters, description="sysid", unit="iter") as bar:
        fitted, _ = sysid.optimize(
            nominal.copy().move_off_bounds(),  # a nominal 0 sits on its bound, where the optimizer can stall
            residual,
            optimizer="mujoco",
            verbose=False,
            max_iters=max_iters,
            output=io.StringIO(),  # its per-iteration lines; the progress bar stands for them
            iter_callback=advance,
        )
        iterations = max(len(logs) - 1, 0)  # mujoco.minimize.least_squares logs the final point after its loop
        bar.n = iterations
        bar.total = iterations  # it stopped when converged: the last line reads 100%
        bar.refresh()
    seconds = time.monotonic() - started
    after = _simulate(residual, fitted)
    measured = [ts.data for ts in before[1]]
    return FitResult(
        nominal=values_of(nominal, scales),
        identified=values_of(fitted, scales),
        rms_before=_rms(before[0], measured),
        rms_after=_rms(after[0], measured),
        simulated_before=[ts.data for ts in before[0]],
        simulated_after=[ts.data for ts in after[0]],
        sample_times=[ts.times for ts in before[1]],
        measured=measured,
        iterations=int(iterations),
        seconds=seconds,
    )


def at_bounds(result: FitResult) -> list[str]:
    """The parameters (`<joint>.<kind>`) that ended at an end of their search range; 0 for a parameter whose
    nominal value is 0 is a value, not the end of a range."""
    ended = []
    for joint, values in result.identified.items():
        for kind, value in values.items():
            nominal = result.nominal[joint][kind]
            low, high = FACTOR_BOUNDS if nominal > 0 else (0.0, FACTOR_BOUNDS[1])
            factor = value / (nominal if nominal > 0 else FLOORS[kind])
            if factor >= high * (1 - BOUND_TOLERANCE) or (low > 0 and factor <= low * (1 + BOUND_TOLERANCE)):
                ended.append(f"{joint}.{kind}")
    return ended


def poorly_tracked(result: FitResult) -> list[str]:
    """The joints whose tracking error after the fit is above POOR_TRACKING_SHARE of their recorded motion."""
    measured = np.concatenate(result.measured)
    motion = np.sqrt(np.mean((measured - measured.mean(axis=0)) ** 2, axis=0))
    joints = list(result.identified)
    return [joints[i] for i in np.flatnonzero(result.rms_after > POOR_TRACKING_SHARE * motion)]


def quality_warning(result: FitResult) -> str | None:
    """One line saying why the fitted values should not be trusted as they are, or None for a sound fit."""
    problems = []
    ended = at_bounds(result)
    if ended:
        low, high = FACTOR_BOUNDS
        problems.append(
            f"{_listed(ended)} ended at the edge of the search range ({low:g}x to {high:g}x the nominal value), so "
            "the arm's value may lie beyond it"
        )
    missed = poorly_tracked(result)
    if missed:
        problems.append(
            f"the calibrated model still misses the recordings of {_listed(missed)} by over "
            f"{POOR_TRACKING_SHARE:.0%} of their motion (a parameter left out of --fit, or something the model lacks)"
        )
    if not problems:
        return None
    return f"poor fit: {'; '.join(problems)}; check the model (units, actuators, nominal values) before using it"


def _listed(names: list[str], shown: int = 4) -> str:
    """The first `shown` names, comma-separated, and how many more."""
    more = f" and {len(names) - shown} more" if len(names) > shown else ""
    return ", ".join(names[:shown]) + more


def _simulate(residual: Callable[..., tuple], parameters: sysid.ParameterDict) -> tuple[list, list]:
    """Simulated and measured joint positions of every recording at its samples, with `parameters`."""
    _, predicted, measured = residual(parameters.as_vector(), parameters.copy())
    return [chunks[0] for chunks in predicted], [chunks[0] for chunks in measured]


def _rms(simulated: list, measured: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    """Root mean square of measured minus simulated, per servo, over the samples of all recordings."""
    errors = np.concatenate([m - s.data for s, m in zip(simulated, measured, strict=True)])
    return np.sqrt(np.mean(errors * errors, axis=0))
