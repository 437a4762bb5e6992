"""Checking a trajectory against a model before replaying it, with every problem tied to its file lines.

Checks: timestamps that go back or repeat, NaN/inf values, joints outside their range, joint speeds
(finite differences) above a limit, and contacts deeper than a threshold along the kinematic replay
(self-penetration between parts of one robot, or penetration of the table and other world geometry).
Runs of consecutive rows with the same problem are reported once, with their line range and worst value.
Rows with a bad timestamp or a non-finite value are left out of the replay; the others are replayed.
Each problem also has its replay time (`line_times`), where a display marks it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from joshua_core.atomic import atomic_write_json, json_safe
from joshua_core.config_pb2 import SimulationConfig
from joshua_core.errors import UsageError
from joshua_core.interfaces import Engine
from joshua_core.trajectory import Trajectory
from joshua_core.trajectory_sources import load_trajectory
from joshua_modes import options_pb2
from joshua_modes.replay import Replayer, model_joint_ranges, qpos_addresses

if TYPE_CHECKING:
    from joshua_core.plugins import PluginHost

DEFAULT_VELOCITY_LIMIT = 10.0  # rad/s (or m/s for slide joints)
DEFAULT_PENETRATION_THRESHOLD = 0.005  # m


@dataclass(frozen=True)
class Issue:
    """One problem, over the rows `first_line`..`last_line` of the file (`rows` of them), replayed from `time`
    (the trajectory time of `first_line`, see `line_times`; NaN when no row is replayed)."""

    kind: str  # "timestamp", "non_finite", "joint_limit", "velocity", "self_penetration", "world_penetration"
    subject: str  # the joint, or the two geoms in contact
    first_line: int
    last_line: int
    rows: int
    worst_line: int
    worst_value: float
    message: str
    time: float = math.nan


@dataclass
class ValidationReport:
    """Every problem found in a trajectory, the rows kept for replay, and (after a tracked replay) its error."""

    trajectory: str
    model: str
    joints: list[str]
    rows: int
    replayed_rows: int
    duration_s: float
    velocity_limit: float
    penetration_threshold: float
    issues: list[Issue] = field(default_factory=list)
    tracking_error: dict[str, dict[str, float]] | None = None

    @property
    def ok(self) -> bool:
        return not self.issues

    def to_json(self) -> dict[str, Any]:
        document = asdict(self)
        document["ok"] = self.ok
        document["issue_counts"] = {kind: sum(i.kind == kind for i in self.issues) for kind in _kinds(self.issues)}
        return json_safe(document)  # a non-finite worst value (a NaN row, an overflowing speed) is null

    def write(self, path: Path) -> None:
        atomic_write_json(path, self.to_json())

    def summary(self) -> str:
        """The report as a few readable lines."""
        head = (
            f"trajectory {self.trajectory}: {self.rows} rows, {self.duration_s:.3f} s, joints {', '.join(self.joints)}"
        )
        if self.ok:
            return (
                f"{head}\n  OK: no problems (velocity limit {self.velocity_limit:g}, penetration threshold "
                f"{self.penetration_threshold * 1000:g} mm)"
            )
        lines = [f"{head}\n  {len(self.issues)} problem(s); {self.replayed_rows} of {self.rows} rows replayable:"]
        lines += [f"  - {issue.message}" for issue in self.issues]
        return "\n".join(lines)


def _kinds(issues: Iterable[Issue]) -> list[str]:
    return sorted({issue.kind for issue in issues})


def validate(
    trajectory: Trajectory,
    model: mujoco.MjModel,
    base_qpos: NDArray[np.float64],
    *,
    model_path: str = "",
    velocity_limit: float = DEFAULT_VELOCITY_LIMIT,
    penetration_threshold: float = DEFAULT_PENETRATION_THRESHOLD,
) -> tuple[ValidationReport, NDArray[np.bool_]]:
    """Check `trajectory` on `model` (joints it does not name stay at `base_qpos`); return the report and
    the mask of rows that can be replayed."""
    issues, usable = _row_issues(trajectory)
    kept = np.flatnonzero(usable)
    times, positions, kept_lines = trajectory.timestamps[kept], trajectory.positions[kept], trajectory.lines[kept]
    issues += _limit_issues(trajectory, model, positions, kept_lines)
    issues += _velocity_issues(trajectory, times, positions, kept_lines, velocity_limit)
    issues += _penetrations(model, base_qpos, trajectory, positions, kept_lines, penetration_threshold)
    issues.sort(key=lambda issue: (issue.first_line, issue.kind, issue.subject))
    starts = line_times(trajectory, usable, [issue.first_line for issue in issues])
    issues = [replace(issue, time=float(start)) for issue, start in zip(issues, starts, strict=True)]
    report = ValidationReport(
        trajectory=str(trajectory.path),
        model=model_path,
        joints=list(trajectory.joint_names),
        rows=trajectory.rows,
        replayed_rows=int(usable.sum()),
        duration_s=float(times[-1] - times[0]) if len(kept) else 0.0,
        velocity_limit=velocity_limit,
        penetration_threshold=penetration_threshold,
        issues=issues,
    )
    return report, usable


def line_times(trajectory: Trajectory, usable: NDArray[np.bool_], lines: Iterable[int]) -> NDArray[np.float64]:
    """The replay time of each file line in `lines`: the timestamp of the last replayed row at or before it (a
    skipped row is passed over there), of the first replayed row for a line before them all; NaN when no row
    is replayed. The one mapping from a file line to the moment of the replay that shows it."""
    wanted = np.asarray(list(lines), dtype=np.int64)
    kept = np.flatnonzero(usable)
    if not kept.size:
        return np.full(len(wanted), math.nan)
    rows = np.searchsorted(trajectory.lines, wanted, side="right") - 1  # the row at or before each line
    before = np.maximum(np.searchsorted(kept, rows, side="right") - 1, 0)  # the last replayed row up to it
    return trajectory.timestamps[kept[before]]


def _row_issues(trajectory: Trajectory) -> tuple[list[Issue], NDArray[np.bool_]]:
    """Rows with a non-finite value or a timestamp that does not increase (each reported, and skipped);
    returns the issues and the mask of the rows kept."""
    name, lines = trajectory.path.name, trajectory.lines
    issues: list[Issue] = []
    finite = np.isfinite(trajectory.timestamps) & np.all(np.isfinite(trajectory.positions), axis=1)
    for row in np.flatnonzero(~finite):
        bad = [
            f"{joint}={trajectory.positions[row, j]}"
            for j, joint in enumerate(trajectory.joint_names)
            if not math.isfinite(trajectory.positions[row, j])
        ]
        if not math.isfinite(trajectory.timestamps[row]):
            bad.insert(0, f"timestamp={trajectory.timestamps[row]}")
        issues.append(_single("non_finite", "row", name, lines[row], float("nan"), f"{', '.join(bad)}; row skipped"))

    usable = finite.copy()
    last_time = -math.inf
    last_row = -1
    for row in np.flatnonzero(finite):
        t = trajectory.timestamps[row]
        if t > last_time:
            last_time, last_row = t, int(row)
            continue
        usable[row] = False
        what = "repeats" if t == last_time else "is before"
        issues.append(
            _single(
                "timestamp",
                "timestamp",
                name,
                lines[row],
                float(t),
                f"timestamp {t:g} {what} the previous one, {last_time:g} (line {lines[last_row]}); row skipped",
            )
        )
    return issues, usable


def _limit_issues(
    trajectory: Trajectory, model: mujoco.MjModel, positions: NDArray[np.float64], kept_lines: NDArray[np.int64]
) -> list[Issue]:
    """Runs of kept rows where a limited joint is outside its range."""
    issues: list[Issue] = []
    for j, joint in enumerate(trajectory.joint_names):
        joint_id = model.joint(joint).id
        if not model.jnt_limited[joint_id]:
            continue
        low, high = model.jnt_range[joint_id]
        excess = np.maximum(low - positions[:, j], positions[:, j] - high)
        issues += _runs(
            "joint_limit",
            joint,
            trajectory.path.name,
            kept_lines,
            excess > 1e-9,
            positions[:, j],
            np.abs(excess),
            lambda where, worst, value, joint=joint, low=low, high=high: (
                f"{where}: {joint} outside its range [{low:g}, {high:g}]: {value:.4g} at line {worst}"
            ),
        )
    return issues


def _velocity_issues(
    trajectory: Trajectory,
    times: NDArray[np.float64],
    positions: NDArray[np.float64],
    kept_lines: NDArray[np.int64],
    velocity_limit: float,
) -> list[Issue]:
    """Runs of kept rows where a joint's finite-difference speed is above `velocity_limit`."""
    if len(times) < 2:
        return []
    issues: list[Issue] = []
    speeds = np.abs(np.diff(positions, axis=0)) / np.diff(times)[:, None]
    for j, joint in enumerate(trajectory.joint_names):
        issues += _runs(
            "velocity",
            joint,
            trajectory.path.name,
            kept_lines[1:],
            speeds[:, j] > velocity_limit,
            speeds[:, j],
            speeds[:, j],
            lambda where, worst, value, joint=joint: (
                f"{where}: {joint} moves at {value:.3g}/s (finite difference), above the limit "
                f"{velocity_limit:g}/s; fastest at line {worst}"
            ),
        )
    return issues


def _single(kind: str, subject: str, name: str, line: int, value: float, text: str) -> Issue:
    return Issue(kind, subject, int(line), int(line), 1, int(line), value, f"{name}:{line}: {text}")


def _where(name: str, first: int, last: int, rows: int) -> str:
    return f"{name}:{first}" if first == last else f"{name}:{first}-{last} ({rows} rows)"


def _runs(
    kind: str,
    subject: str,
    name: str,
    lines: NDArray[np.int64],
    flagged: NDArray[np.bool_],
    values: NDArray[np.float64],
    severity: NDArray[np.float64],
    describe: Any,
) -> list[Issue]:
    """One Issue per run of consecutive flagged rows; `describe(where, worst_line, worst_value)` words it."""
    issues: list[Issue] = []
    indices = np.flatnonzero(flagged)
    if not indices.size:
        return issues
    breaks = np.flatnonzero(np.diff(indices) > 1)
    for run in np.split(indices, breaks + 1):
        worst = run[np.argmax(severity[run])]
        first, last = int(lines[run[0]]), int(lines[run[-1]])
        where = _where(name, first, last, len(run))
        issues.append(
            Issue(
                kind,
                subject,
                first,
                last,
                len(run),
                int(lines[worst]),
                float(values[worst]),
                describe(where, int(lines[worst]), float(values[worst])),
            )
        )
    return issues


def _penetrations(
    model: mujoco.MjModel,
    base_qpos: NDArray[np.float64],
    trajectory: Trajectory,
    positions: NDArray[np.float64],
    lines: NDArray[np.int64],
    threshold: float,
) -> list[Issue]:
    """Geom pairs deeper than `threshold` into each other at each replayed row's pose, grouped per pair.

    World pairs (table, floor) come from MuJoCo's collision detection. Pairs within one robot are
    measured directly with mj_geomDistance, because models usually filter self-collisions out.
    """
    data = mujoco.MjData(model)
    addresses = qpos_addresses(model, trajectory.joint_names)
    first, second = _self_pairs(model)
    reach = model.geom_rbound[first] + model.geom_rbound[second]
    depth: dict[tuple[int, int], NDArray[np.float64]] = {}

    def record(pair: tuple[int, int], row: int, penetration: float) -> None:
        pair_depths = depth.setdefault((min(pair), max(pair)), np.zeros(len(positions)))
        pair_depths[row] = max(pair_depths[row], penetration)

    for row in range(len(positions)):
        data.qpos[:] = base_qpos
        data.qpos[addresses] = positions[row]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_collision(model, data)
        for contact in data.contact[: data.ncon]:
            if contact.dist < -threshold:
                record((contact.geom1, contact.geom2), row, -contact.dist)
        near = np.linalg.norm(data.geom_xpos[first] - data.geom_xpos[second], axis=1) < reach
        for geom1, geom2 in zip(first[near], second[near], strict=True):
            distance = mujoco.mj_geomDistance(model, data, geom1, geom2, 0.0, None)
            if distance < -threshold:
                record((int(geom1), int(geom2)), row, -distance)
    issues = []
    for (geom1, geom2), depths in depth.items():
        body1, body2 = model.geom_bodyid[geom1], model.geom_bodyid[geom2]
        world = model.body_rootid[body1] == 0 or model.body_rootid[body2] == 0
        kind = "world_penetration" if world else "self_penetration"
        label = "penetrates" if world else "self-penetration:"
        subject = f"{_geom_name(model, geom1)} / {_geom_name(model, geom2)}"
        issues += _runs(
            kind,
            subject,
            trajectory.path.name,
            lines,
            depths > 0,
            depths,
            depths,
            lambda where, worst, value, subject=subject, label=label: (
                f"{where}: {label} {subject} {value * 1000:.1f} mm deep (threshold {threshold * 1000:g} mm), "
                f"deepest at line {worst}"
            ),
        )
    return issues


def _self_pairs(model: mujoco.MjModel) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Pairs of collision geoms of one robot (same root body) on bodies that are neither equal nor
    parent and child (touching at their joint is by design)."""
    geoms = [g for g in range(model.ngeom) if model.geom_contype[g] or model.geom_conaffinity[g]]
    pairs = []
    for i, geom1 in enumerate(geoms):
        for geom2 in geoms[i + 1 :]:
            body1, body2 = model.geom_bodyid[geom1], model.geom_bodyid[geom2]
            if (
                body1 != body2
                and model.body_rootid[body1] == model.body_rootid[body2] != 0
                and model.body_parentid[body1] != body2
                and model.body_parentid[body2] != body1
            ):
                pairs.append((geom1, geom2))
    columns = np.array(pairs, dtype=np.int64).reshape(-1, 2)
    return columns[:, 0], columns[:, 1]


def _geom_name(model: mujoco.MjModel, geom: int) -> str:
    """The geom's name, else 'geom N of body B'."""
    name = model.geom(geom).name
    return name or f"geom {geom} of body {model.body(model.geom_bodyid[geom]).name or model.geom_bodyid[geom]}"


def validated_replayer(
    config: SimulationConfig,
    engine: Engine,
    report_path: Path,
    *,
    replay: options_pb2.ReplayOptions,
    refusal: str,
    plugins: PluginHost,
    staged_at: Path | None = None,
) -> tuple[Replayer, ValidationReport]:
    """Load (CSV, or a dataset through a plugin's reader; episode `replay.episode`) and validate
    `config.trajectory_path` against the engine's model, print the report and write it as JSON (to `staged_at`
    when given: a caller that publishes all its outputs together moves it to `report_path`); return the
    replayer of its usable rows. `replay`: the config's replay options, which the mode read. With
    `replay.strict` and any problem, raise UsageError ending in `refusal` (what was not done) instead."""
    trajectory = load_trajectory(
        config.trajectory_path, model_joint_ranges(engine.model), episode=replay.episode, plugins=plugins
    )
    report, usable = validate(
        trajectory,
        engine.model,
        engine.data.qpos.copy(),
        model_path=config.model_path,
        velocity_limit=replay.velocity_limit or DEFAULT_VELOCITY_LIMIT,
        penetration_threshold=replay.penetration_threshold or DEFAULT_PENETRATION_THRESHOLD,
    )
    report.write(staged_at or report_path)
    print(report.summary())
    print(f"validation report: {report_path}")
    if replay.strict and not report.ok:
        raise UsageError(
            f"the trajectory has {len(report.issues)} problem(s) (listed above, and in {report_path}); {refusal}"
        )
    return Replayer(engine, trajectory, usable, tracked=replay.tracked), report
