"""What a fit leaves in its run folder: the calibrated model (MJCF with its meshes beside it), report.json,
the tracking plot, and the table printed on the terminal. Every file is written atomically."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from joshua_core.atomic import atomic_write_bytes, atomic_write_json
from joshua_core.outputs import check_inside
from joshua_sysid.calibrated import REPORT_FILE
from joshua_sysid.fit import KINDS, FitResult, at_bounds, poorly_tracked, write_value
from joshua_sysid.recordings import Recording, Servo

PLOT_FILE = "tracking.png"
ASSETS_DIR = "assets"  # the model's mesh, texture, height-field and skin files, copied beside it


def write_model(spec: mujoco.MjSpec, result: FitResult, servos: list[Servo], folder: Path, name: str) -> Path:
    """Write `spec` with the identified values as `folder/name` (MjSpec.to_xml), its asset files copied into
    `folder/assets/`, so that it compiles from there wherever the run folder goes."""
    calibrated = spec.copy()
    for servo in servos:
        for kind, value in result.identified.get(servo.joint, {}).items():
            write_value(calibrated, servo, kind, value)
    _bundle_assets(calibrated, folder)
    path = folder / name
    atomic_write_bytes(path, calibrated.to_xml().encode())
    return path


def _bundle_assets(spec: mujoco.MjSpec, folder: Path) -> None:
    """Copy every asset file the spec names into `folder/assets/` and point the spec's asset folders there.

    A file named by a plain relative path keeps it; one named by an absolute path or one that climbs out with
    `..` is copied under its base name (made unique), and the spec (a copy, never the caller's model) is
    rewritten to that name: every copy lands inside `folder`."""
    source = Path(spec.modelfiledir or ".")
    assets = folder / ASSETS_DIR
    copied: dict[str, Path] = {}  # name in assets/ -> the file copied there
    groups = [(spec.meshdir, [*spec.meshes, *spec.hfields, *spec.skins]), (spec.texturedir, list(spec.textures))]
    for directory, elements in groups:
        for element in elements:
            if not element.file:
                continue  # generated or in-memory (a USD reader's meshes)
            origin = (source / directory / element.file).resolve()
            name = _asset_name(element.file, origin, copied)
            if name not in copied:
                target = check_inside(assets, assets / name, "asset")
                target.parent.mkdir(parents=True, exist_ok=True)
                with open(origin, "rb") as handle:
                    atomic_write_bytes(target, handle.read())
                copied[name] = origin
            element.file = name
    spec.meshdir = f"{ASSETS_DIR}/"
    spec.texturedir = f"{ASSETS_DIR}/"
    spec.modelfiledir = f"{folder}/"  # MjSpec.to_xml compiles: it reads the copies, where the model now names them


def _asset_name(written: str, origin: Path, copied: dict[str, Path]) -> str:
    """The name under assets/ for the file `origin` (written as `written` in the model): `written` when it is a
    plain relative path, else its base name; `_2`, `_3`... before the suffix when another file has that name."""
    path = Path(written)
    plain = not path.is_absolute() and ".." not in path.parts and "\\" not in written
    wanted = path.as_posix() if plain else path.name
    stem, suffix = Path(wanted).with_suffix("").as_posix(), Path(wanted).suffix
    name, number = wanted, 1
    while copied.get(name, origin) != origin:
        number += 1
        name = f"{stem}_{number}{suffix}"
    return name


def report_document(
    result: FitResult, servos: list[Servo], recordings: list[Recording], model_path: Path, outputs: dict[str, str]
) -> dict[str, Any]:
    """The content of report.json."""
    joints = [servo.joint for servo in servos]
    before = float(np.sqrt(np.mean(result.rms_before**2)))
    after = float(np.sqrt(np.mean(result.rms_after**2)))
    return {
        "model": str(model_path),
        "recordings": [
            {"path": str(r.path), "samples": len(r.times), "seconds": float(r.times[-1])} for r in recordings
        ],
        "parameters": {
            joint: {
                kind: {"nominal": result.nominal[joint][kind], "identified": result.identified[joint][kind]}
                for kind in result.identified[joint]
            }
            for joint in joints
        },
        "tracking_rms": {
            "unit": "rad (m for slide joints)",
            "before": dict(zip(joints, map(float, result.rms_before), strict=True)),
            "after": dict(zip(joints, map(float, result.rms_after), strict=True)),
            "overall_before": before,
            "overall_after": after,
            "reduction_factor": before / after if after > 0 else None,
        },
        "fit": {
            "iterations": result.iterations,
            "seconds": result.seconds,
            "at_bounds": at_bounds(result),  # parameters that ended at an end of their search range
            "poorly_tracked": poorly_tracked(result),  # joints the calibrated model still misses
        },
        "outputs": outputs,
    }


def table(result: FitResult, servos: list[Servo]) -> str:
    """The parameters (nominal -> identified) and tracking errors per joint, as aligned text."""
    kinds = [kind for kind in KINDS if kind in result.identified[servos[0].joint]]
    header = ["joint", *kinds, "rms before (rad)", "rms after (rad)"]
    rows = [header]
    for index, servo in enumerate(servos):
        cells = [f"{result.nominal[servo.joint][k]:.4g} -> {result.identified[servo.joint][k]:.4g}" for k in kinds]
        rows.append([servo.joint, *cells, f"{result.rms_before[index]:.2e}", f"{result.rms_after[index]:.2e}"])
    widths = [max(len(row[column]) for row in rows) for column in range(len(header))]
    return "\n".join("  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=True)) for row in rows)


def write_plot(result: FitResult, servos: list[Servo], path: Path) -> None:
    """Per joint, the first recording's measured position against the nominal and the calibrated model's."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot

    figure, axes = pyplot.subplots(len(servos), 1, figsize=(9, 1.9 * len(servos)), sharex=True, squeeze=False)
    times = result.sample_times[0]
    for index, (servo, axis) in enumerate(zip(servos, axes[:, 0], strict=True)):
        axis.plot(times, result.measured[0][:, index], color="black", linewidth=1.6, label="recorded")
        axis.plot(times, result.simulated_before[0][:, index], "--", color="tab:red", label="nominal model")
        axis.plot(times, result.simulated_after[0][:, index], ":", color="tab:green", linewidth=2, label="calibrated")
        axis.set_ylabel(f"{servo.joint}\n(rad)")
        axis.set_title(
            f"RMS error {result.rms_before[index]:.2e} -> {result.rms_after[index]:.2e}", fontsize=8, loc="right"
        )
    axes[0, 0].legend(loc="upper left", fontsize=8, ncol=3)
    axes[-1, 0].set_xlabel("time (s)")
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=90)
    pyplot.close(figure)
    atomic_write_bytes(path, buffer.getvalue())


def write_report(document: dict[str, Any], folder: Path) -> Path:
    path = folder / REPORT_FILE
    atomic_write_json(path, document)
    return path
