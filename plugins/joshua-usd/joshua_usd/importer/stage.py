"""The composed stage and its units: every prim's world transform in MuJoCo's frame (metres, Z up), and
attribute readers that turn bad values into one-line ModelErrors."""

from __future__ import annotations

import math
import reprlib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pxr import Gf, Tf, Usd, UsdGeom, UsdPhysics

from joshua_usd.importer.pose import Pose, Vec, decompose
from joshua_usd.importer.report import ImportReport
from joshua_usd.physx_schema import attribute_name

# A transform whose smallest singular value is this small against its largest collapses an axis (a scale of 0, or
# two axes onto one): no pose or size can be read from it.
SINGULAR_RATIO = 1e-12
INT32_LIMIT = 2**31  # MuJoCo's integer fields are 32-bit


def open_stage(path: Path, report: ImportReport) -> Usd.Stage:
    """The composed stage (sublayers, references, payloads and variants resolved). A stage that does not compose
    as written (a sublayer or referenced layer that cannot be read, ...) or whose prims have a non-finite
    transform is a ModelError naming the layer or prim: importing what is left would give a wrong robot."""
    try:
        stage = Usd.Stage.Open(str(path), Usd.Stage.LoadAll)
    except Tf.ErrorException as error:
        detail = " ".join(str(error).split())
        raise report.error("/", "layer", f"cannot open the stage: {detail}") from None
    if stage is None:
        raise report.error("/", "layer", "cannot open the stage")
    errors = stage.GetCompositionErrors()
    if errors:
        more = f" (and {len(errors) - 1} more composition error(s))" if len(errors) > 1 else ""
        raise report.error("/", "layer", f"cannot compose the stage: {' '.join(str(errors[0]).split())}{more}")
    _check_transforms(stage, report)
    return stage


def _check_transforms(stage: Usd.Stage, report: ImportReport) -> None:
    """A ModelError naming the first prim whose local transform holds a NaN or an infinity."""
    for prim in prims(stage):
        if prim.IsA(UsdGeom.Xformable):
            matrix = np.array(UsdGeom.Xformable(prim).GetLocalTransformation(Usd.TimeCode.Default()))
            if not np.isfinite(matrix).all():
                raise report.error(prim.GetPath(), "xformOp", "the transform is not finite (NaN or infinity)")


def prims(stage: Usd.Stage) -> Iterator[Usd.Prim]:
    """Every active, defined prim, instance proxies included (so instanced colliders and bodies count)."""
    return iter(Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))


@dataclass(frozen=True)
class StageFrame:
    """How stage coordinates map to MuJoCo's: `to_mujoco` scales to metres and turns a Y-up world to Z-up;
    `report` is the import's, for the transforms that place nothing."""

    meters_per_unit: float
    kilograms_per_unit: float
    up_axis: str
    to_mujoco: NDArray[np.float64]
    report: ImportReport

    @classmethod
    def of(cls, stage: Usd.Stage, report: ImportReport) -> StageFrame:
        """Read metersPerUnit, kilogramsPerUnit and upAxis of the stage."""
        meters = float(UsdGeom.GetStageMetersPerUnit(stage))
        kilograms = float(UsdPhysics.GetStageKilogramsPerUnit(stage))
        for name, value in (("metersPerUnit", meters), ("kilogramsPerUnit", kilograms)):
            if not math.isfinite(value) or value <= 0:
                raise report.error("/", name, f"must be a positive number, got {value}")
        up = str(UsdGeom.GetStageUpAxis(stage))
        matrix = np.eye(4)
        matrix[:3, :3] = meters * (np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]) if up == "Y" else np.eye(3))
        return cls(meters, kilograms, up, matrix, report)

    def joint_units(self, angular: bool) -> tuple[float, float]:
        """(SI per stage unit of position, SI per stage unit of force or torque) of an angular or linear joint: USD
        measures angles in degrees."""
        kilograms, meters = self.kilograms_per_unit, self.meters_per_unit
        if angular:
            return math.pi / 180, kilograms * meters**2
        return meters, kilograms * meters

    def world_matrix(self, prim: Usd.Prim | None) -> NDArray[np.float64]:
        """The prim's local-to-world matrix in MuJoCo's world (column vectors); None is the world itself. A singular
        one (a scale of 0 on the prim or above it) is a ModelError naming the prim whose own transform collapses."""
        if prim is None or prim.IsPseudoRoot():
            return self.to_mujoco
        if not prim.IsA(UsdGeom.Xformable):  # a type usd-core has no schema for (Isaac's sensors): its own ops
            matrix = self.world_matrix(prim.GetParent()) @ _local_matrix(prim)
        else:
            stage_matrix = UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
            matrix = self.to_mujoco @ np.array(stage_matrix).T
        if _singular(matrix):
            collapsing = next((above for above in _ancestry(prim) if _singular(_local_matrix(above))), prim)
            placed = "" if collapsing == prim else f", which places {prim.GetPath()}"
            raise self.report.error(
                collapsing.GetPath(),
                "xformOp",
                "the transform is singular (a scale of 0, or axes collapsed onto each other): no pose or size can be "
                f"read from it{placed}",
            )
        return matrix

    def world_pose(self, prim: Usd.Prim | None) -> tuple[Pose, Vec]:
        """The prim's rigid pose in MuJoCo's world and the scale (metres per local unit) along its axes."""
        return decompose(self.world_matrix(prim))


def _singular(matrix: NDArray[np.float64]) -> bool:
    """Whether the linear part of a 4x4 transform (finite: `open_stage` checked) collapses an axis."""
    singular_values = np.linalg.svd(matrix[:3, :3], compute_uv=False)
    return not singular_values[-1] > SINGULAR_RATIO * singular_values[0]


def _ancestry(prim: Usd.Prim) -> Iterator[Usd.Prim]:
    """`prim` and its ancestors, nearest first, up to the stage's root prims."""
    while prim and not prim.IsPseudoRoot():
        yield prim
        prim = prim.GetParent()


def _local_matrix(prim: Usd.Prim) -> NDArray[np.float64]:
    """The local transform (column vectors) of the xformOps named in the prim's xformOpOrder."""
    matrix = Gf.Matrix4d(1)
    order = prim.GetAttribute("xformOpOrder")
    names = order.Get() if order else None
    for name in names or []:
        attribute = prim.GetAttribute(str(name))
        if attribute:  # "!resetXformStack!" and missing ops add nothing
            matrix = UsdGeom.XformOp(attribute).GetOpTransform(Usd.TimeCode.Default()) * matrix
    return np.array(matrix).T


def read(prim: Usd.Prim, name: str, report: ImportReport, *, allow_inf: bool = False) -> Any:
    """The value of attribute `name` (authored or the schema fallback), None when it has none; a NaN (or an
    infinity unless `allow_inf`) is a ModelError naming the prim and attribute. An authored value counts as used
    (`ImportReport.used`) unless the caller says otherwise (`ImportReport.ignore`)."""
    attribute = prim.GetAttribute(name)
    if not attribute or not attribute.HasValue():
        return None
    if attribute.HasAuthoredValue():
        report.used.add((str(prim.GetPath()), name))
    value = attribute.Get()
    numbers = np.asarray(_numeric(value), dtype=np.float64)
    if numbers.size and (np.isnan(numbers).any() or (not allow_inf and np.isinf(numbers).any())):
        raise report.error(prim.GetPath(), name, f"is not a finite number: {value}")
    return value


def read_number(
    prim: Usd.Prim,
    name: str,
    report: ImportReport,
    *,
    integer: bool = False,
    authored: bool = False,
    allow_inf: bool = False,
) -> float | None:
    """The value of attribute `name` as a number (checked as `read` checks), None when it has none (or, where
    `authored`, none authored). A value of another type (a string, an array) is a ModelError naming the prim and
    attribute, as is, where `integer`, one that is not a whole number MuJoCo's 32-bit integers hold."""
    value = (read_authored if authored else read)(prim, name, report, allow_inf=allow_inf)
    if value is None:
        return None
    if not isinstance(value, int | float):  # bool is an int: USD's bool attributes read as 0 or 1
        raise report.error(prim.GetPath(), name, f"must be a number, got {reprlib.repr(value)}")
    if integer and not (float(value).is_integer() and -INT32_LIMIT <= value < INT32_LIMIT):
        raise report.error(prim.GetPath(), name, f"must be a whole number within 32 bits, got {value}")
    return int(value) if integer else float(value)


def read_authored(prim: Usd.Prim, name: str, report: ImportReport, *, allow_inf: bool = False) -> Any:
    """The authored value of attribute `name`, None when unauthored (a registered schema's fallback is not read:
    the importer names the fallbacks it relies on itself, so a stage imports the same with or without the schema
    registered). Checked as `read` checks."""
    return read(prim, name, report, allow_inf=allow_inf) if prim.GetAttribute(name).HasAuthoredValue() else None


def applied(prim: Usd.Prim, api: str) -> bool:
    """Whether the API schema `api` is applied to `prim`, registered with USD or not (MuJoCo's and Newton's
    schemas usually are not)."""
    return api in prim.GetPrimTypeInfo().GetAppliedAPISchemas()


def read_array(prim: Usd.Prim, name: str, size: int, report: ImportReport) -> np.ndarray | None:
    """The authored array of `size` numbers at attribute `name`, None when unauthored; another length or type is a
    ModelError naming the prim and attribute (MuJoCo holds exactly `size` numbers there)."""
    value = read_authored(prim, name, report)
    if value is None:
        return None
    numbers = np.asarray(_numeric(value), dtype=np.float64)
    if isinstance(value, str) or numbers.shape != (size,):
        raise report.error(prim.GetPath(), name, f"must be {size} numbers, got {reprlib.repr(value)}")
    return numbers


def read_physx(
    prim: Usd.Prim, api: str, key: str, report: ImportReport, *, instance: str = "", allow_inf: bool = False
) -> Any:
    """The authored value of property `key` of the PhysX API schema `api` (its `instance` where multiple-apply),
    named by the PhysX schemas; None when unauthored: their fallbacks are PhysX's defaults, not MuJoCo's, so a
    stage imports the same with the schemas registered or not. Checked as `read` checks."""
    return read_authored(prim, attribute_name(api, key, instance), report, allow_inf=allow_inf)


def _numeric(value: Any) -> Any:
    """The numbers in a USD value (quaternions as w, x, y, z), or [] for a non-numeric one."""
    if hasattr(value, "GetReal"):
        return [value.GetReal(), *value.GetImaginary()]
    if isinstance(value, bool | str) or value is None:
        return []
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        return []


def read_quat(prim: Usd.Prim, name: str, report: ImportReport) -> Vec | None:
    """A quaternion attribute as a normalized w-x-y-z array; None when unauthored or all zero."""
    value = read(prim, name, report)
    if value is None:
        return None
    q = np.asarray(_numeric(value), dtype=np.float64)
    return q / np.linalg.norm(q) if np.linalg.norm(q) > 0 else None


def positive(prim: Usd.Prim, name: str, value: float, report: ImportReport) -> float:
    """`value` if not negative; a negative mass, density or inertia is a ModelError."""
    if value < 0:
        raise report.error(prim.GetPath(), name, f"must not be negative, got {value}")
    return float(value)
