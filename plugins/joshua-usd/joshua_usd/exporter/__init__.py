"""MuJoCo -> USD: a UsdPhysics articulation Isaac loads, written from the compiled model at qpos0.

Layout: /<model> (default prim, ArticulationRootAPI) holds the bodies as sibling rigid-body Xforms
in world poses, the `joints` Scope, `Looks` and `PhysicsMaterials`; /PhysicsScene, /CollisionGroups and
/Environment (world geoms and cameras) lie beside it, so referencing the file's default prim brings the robot only.
The output is text (usda, also in .usd files), byte-identical when rerun, and written atomically.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import mujoco
from pxr import Sdf, Tf, Usd, UsdGeom, UsdPhysics, Vt

from joshua_core.errors import ModelError, UsageError
from joshua_usd.exporter.bodies import write_bodies, write_root, write_scene
from joshua_usd.exporter.context import NOTES_ATTR, Context, set_raw
from joshua_usd.exporter.filtering import write_filtering
from joshua_usd.exporter.geoms import write_geoms
from joshua_usd.exporter.joints import write_drives, write_joints
from joshua_usd.exporter.sensors import write_cameras, write_sensors

TEXT_SUFFIXES = (".usd", ".usda")


def export_model(model_path: Path, out: Path) -> Path:
    """Write the MuJoCo model at `model_path` to `out` (.usd/.usda as text, .usdc as crate); returns
    the written path. Raises ModelError when the model does not compile or cannot be expressed,
    UsageError when `out` has another suffix or cannot be written."""
    from joshua_mujoco import compile_model

    _check_suffix(Path(out))
    try:
        model = compile_model(Path(model_path))
    except ModelError as error:
        raise ModelError(" ".join(str(error).split())) from None
    return write_model(model, out)


def write_model(model: mujoco.MjModel, out: Path) -> Path:
    """Write a compiled model to `out` as `export_model` does (for models assembled in code)."""
    out = Path(out)
    _check_suffix(out)
    stage = build_stage(model)  # held: the layer lives only as long as its stage
    _write_layer(stage.GetRootLayer(), out)
    return out


def _check_suffix(out: Path) -> None:
    """UsageError unless `out` is a .usd, .usda or .usdc file."""
    if out.suffix.lower() not in (*TEXT_SUFFIXES, ".usdc"):
        raise UsageError(f"{out}: write .usd, .usda or .usdc")


def build_stage(model: mujoco.MjModel) -> Usd.Stage:
    """The USD stage of a compiled model, in memory."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)  # a fresh MjData holds qpos0: the reference configuration
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    name = model.names.split(b"\0", 1)[0].decode()  # MuJoCo stores the model's name first
    root = Sdf.Path.absoluteRootPath.AppendChild(Tf.MakeValidIdentifier(name or "robot"))
    ctx = Context(model, data, stage, root)
    write_scene(ctx)
    write_root(ctx)
    write_bodies(ctx)
    write_drives(ctx, write_joints(ctx))
    write_geoms(ctx)
    write_filtering(ctx)
    write_cameras(ctx)
    write_sensors(ctx)
    if ctx.notes:
        notes = Vt.StringArray(ctx.notes)
        set_raw(stage.GetPrimAtPath(root), NOTES_ATTR, Sdf.ValueTypeNames.StringArray, notes, custom=True)
    return stage


def _write_layer(layer: Sdf.Layer, out: Path) -> None:
    """Write through a temporary file in the target folder and os.replace, so `out` is either the old
    file or the complete new one."""
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(prefix=f".{out.stem}.", suffix=out.suffix, dir=out.parent)
    except OSError as error:
        raise UsageError(f"cannot write {out}: {error.strerror or error}") from None
    try:
        if out.suffix.lower() in TEXT_SUFFIXES:
            with os.fdopen(handle, "w", encoding="utf-8") as file:
                file.write(layer.ExportToString())
        else:
            os.close(handle)
            if not layer.Export(temporary):
                raise OSError(f"USD could not write {temporary}")
        os.chmod(temporary, 0o644)
        os.replace(temporary, out)
    except OSError as error:
        Path(temporary).unlink(missing_ok=True)
        raise UsageError(f"cannot write {out}: {error}") from None
