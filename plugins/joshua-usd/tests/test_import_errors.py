"""Broken stages: each is a ModelError of one line naming the file, the prim and the attribute."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics

sys.path.insert(0, str(Path(__file__).parent))

from usd_stages import body, joint, new_stage  # noqa: E402

from joshua_core.errors import ModelError  # noqa: E402
from joshua_usd.importer import import_usd  # noqa: E402


def two_bodies_and_a_hinge(stage: Usd.Stage) -> Usd.Prim:
    first, second = body(stage, "/World/a"), body(stage, "/World/b")
    return joint(stage, UsdPhysics.RevoluteJoint, "/World/hinge", first, second, (0, 0, 0))


def missing_target(stage: Usd.Stage) -> None:
    hinge = two_bodies_and_a_hinge(stage)
    hinge.GetRelationship("physics:body1").SetTargets(["/World/nowhere"])


def not_finite(stage: Usd.Stage) -> None:
    hinge = two_bodies_and_a_hinge(stage)
    hinge.GetAttribute("physics:localPos1").Set(Gf.Vec3f(0, float("nan"), 0))


def negative_mass(stage: Usd.Stage) -> None:
    UsdPhysics.MassAPI.Apply(body(stage, "/World/hinge")).CreateMassAttr(-2.0)


def loop(stage: Usd.Stage) -> None:
    a, b, c = (body(stage, f"/World/{name}") for name in "abc")
    joint(stage, UsdPhysics.RevoluteJoint, "/World/ab", a, b, (0, 0, 0))
    joint(stage, UsdPhysics.RevoluteJoint, "/World/hinge", b, c, (0, 0, 0))  # found last, breadth first from a
    joint(stage, UsdPhysics.RevoluteJoint, "/World/ca", c, a, (0, 0, 0))


def inverted_limits(stage: Usd.Stage) -> None:
    hinge = two_bodies_and_a_hinge(stage)
    UsdPhysics.RevoluteJoint(hinge).CreateLowerLimitAttr(30.0)
    UsdPhysics.RevoluteJoint(hinge).CreateUpperLimitAttr(-30.0)


def infinite_translate(stage: Usd.Stage) -> None:
    two_bodies_and_a_hinge(stage)
    UsdGeom.Xform.Define(stage, "/World/hinge/frame").AddTranslateOp().Set(Gf.Vec3d(float("inf"), 0, 0))


def mjc_value(name: str, kind: Sdf.ValueTypeName, value: object) -> Callable[[Usd.Stage], None]:
    """A stage whose hinge is driven by an MjcActuator (MuJoCo's USD schema, unknown to usd-core, so any type can
    be authored) with attribute `name` of type `kind` set to `value`."""

    def author(stage: Usd.Stage) -> None:
        two_bodies_and_a_hinge(stage)
        actuator = stage.DefinePrim("/World/hinge/servo", "MjcActuator")
        actuator.CreateRelationship("mjc:target", custom=False).SetTargets(["/World/hinge"])
        actuator.CreateAttribute(name, kind, custom=False, variability=Sdf.VariabilityUniform).Set(value)

    author.__name__ = f"{name}={value!r}"
    return author


def scaled_to_zero(stage: Usd.Stage) -> None:
    two_bodies_and_a_hinge(stage)
    UsdGeom.Xformable(stage.GetPrimAtPath("/World/b")).AddScaleOp().Set(Gf.Vec3f(1, 0, 1))


def collapsed_matrix(stage: Usd.Stage) -> None:
    """A body whose transform maps its x and y axes onto one line (rank 2, no zero scale anywhere)."""
    two_bodies_and_a_hinge(stage)
    matrix = Gf.Matrix4d(1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1)
    UsdGeom.Xformable(stage.GetPrimAtPath("/World/b")).AddTransformOp().Set(matrix)


def parent_scaled_to_zero(stage: Usd.Stage) -> None:
    """The bodies under an Xform of scale 0: the error names that Xform, whose own transform collapses."""
    UsdGeom.Xform.Define(stage, "/World/robot").AddScaleOp().Set(Gf.Vec3f(0, 0, 0))
    first, second = body(stage, "/World/robot/a"), body(stage, "/World/robot/b")
    joint(stage, UsdPhysics.RevoluteJoint, "/World/robot/hinge", first, second, (0, 0, 0))


MUST_BE_NUMBERS = "must be an array of numbers"
SINGULAR = "the transform is singular (a scale of 0, or axes collapsed onto each other)"
CASES: list[tuple[Callable[[Usd.Stage], None], str, str, str]] = [
    (missing_target, "/World/hinge", "physics:body1", "does not exist"),
    (not_finite, "/World/hinge", "physics:localPos1", "not a finite number"),
    (negative_mass, "/World/hinge", "physics:mass", "must not be negative"),
    (loop, "/World/hinge", "physics:body1", "kinematic loop"),
    (inverted_limits, "/World/hinge", "physics:lowerLimit", "above upperLimit"),
    (infinite_translate, "/World/hinge/frame", "xformOp", "the transform is not finite"),
    (mjc_value("mjc:gear", Sdf.ValueTypeNames.StringArray, ["a"]), "/World/hinge/servo", "mjc:gear", MUST_BE_NUMBERS),
    (mjc_value("mjc:gear", Sdf.ValueTypeNames.Double, 2.0), "/World/hinge/servo", "mjc:gear", MUST_BE_NUMBERS),
    (mjc_value("mjc:gear", Sdf.ValueTypeNames.String, "12"), "/World/hinge/servo", "mjc:gear", MUST_BE_NUMBERS),
    (mjc_value("mjc:group", Sdf.ValueTypeNames.String, "abc"), "/World/hinge/servo", "mjc:group", "must be a number"),
    (mjc_value("mjc:group", Sdf.ValueTypeNames.Double, 1e30), "/World/hinge/servo", "mjc:group", "within 32 bits"),
    (mjc_value("mjc:group", Sdf.ValueTypeNames.Double, 1.5), "/World/hinge/servo", "mjc:group", "a whole number"),
    (mjc_value("mjc:inheritRange", Sdf.ValueTypeNames.FloatArray, [1.0]), "/World/hinge/servo", "mjc:inheritRange",
     "must be a number"),
    (mjc_value("mjc:ctrlRange:max", Sdf.ValueTypeNames.Token, "x"), "/World/hinge/servo", "mjc:ctrlRange:max",
     "must be a number"),
    (scaled_to_zero, "/World/b", "xformOp", SINGULAR),
    (collapsed_matrix, "/World/b", "xformOp", SINGULAR),
    (parent_scaled_to_zero, "/World/robot", "xformOp", "read from it, which places /World/robot/"),
]  # fmt: skip


@pytest.mark.parametrize(("author", "prim", "attribute", "reason"), CASES, ids=[case[0].__name__ for case in CASES])
def test_broken_stage_is_one_line_naming_file_prim_and_attribute(
    tmp_path: Path, author: Callable[[Usd.Stage], None], prim: str, attribute: str, reason: str
) -> None:
    path = tmp_path / "broken.usda"
    stage = new_stage(path)
    author(stage)
    stage.Save()
    with pytest.raises(ModelError) as caught:
        import_usd(path)
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: {prim}: {attribute}: ") and reason in message


def test_an_unreadable_file_is_a_model_error(tmp_path: Path) -> None:
    path = tmp_path / "garbage.usda"
    path.write_text("#usda 1.0\n(\n  this is not usd\n")
    with pytest.raises(ModelError, match=f"^{path}: /: layer: cannot open the stage") as caught:
        import_usd(path)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize("arc", ["sublayer", "reference"])
def test_a_layer_that_cannot_be_read_is_a_model_error_naming_it(tmp_path: Path, arc: str) -> None:
    """A missing sublayer or referenced layer would import as an empty robot: it is an error naming the layer."""
    path = tmp_path / "robot.usda"
    stage = new_stage(path)
    if arc == "sublayer":
        stage.GetRootLayer().subLayerPaths.append("./missing_layer.usda")
    else:
        stage.DefinePrim("/World/robot").GetReferences().AddReference("./missing_layer.usda")
    stage.Save()
    with pytest.raises(ModelError) as caught:
        import_usd(path)
    message = str(caught.value)
    assert "\n" not in message and message.startswith(f"{path}: /: layer: cannot compose the stage: ")
    assert f"{tmp_path / 'missing_layer.usda'}" in message
