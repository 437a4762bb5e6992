"""The PhysX USD schemas (`physx-usd-schemas`, the `physx` extra) with usd-core's stock `pxr`: registered when this
module is first imported, the names of the PhysX attributes the exporter writes and the importer reads taken from
their applied API schemas, and the check of a stage against those schemas.

The schemas are codeless (plugInfo.json and generatedSchema.usda, no compiled classes): usd-core learns them from
`Plug.Registry` and answers through `Usd.SchemaRegistry`. USD builds that registry once, at its first use, and
ignores plugins registered later (ovphysx docs/physics_schemas.md), so the exporter and importer import this module
before they open or create a stage. Without the extra, names follow the schemas' own convention (an API's
namespace is its name less "API", lower camel case: PhysxCollisionAPI -> physxCollision) and nothing is checked.
"""

from __future__ import annotations

from functools import cache

import mujoco
from pxr import Sdf, Usd

try:
    import physx_usd_schemas  # noqa: F401 -- registers the PhysX schemas with pxr on import
except ImportError:  # the `physx` extra is not installed
    pass

INSTALL = "pip install 'joshua-usd[physx]'"
PREFIX = "physx"  # the namespace of every PhysX schema attribute and the name of every PhysX API schema, lower case
# The PhysxJointAxisAPI instances PhysX reads per joint type (ovphysx docs/population/PhysxJointAxisAPI.md): a
# revolute joint's "angular", a prismatic joint's "linear", a spherical joint's "rotX", "rotY", "rotZ" (twist, swings).
JOINT_AXES = {
    mujoco.mjtJoint.mjJNT_HINGE: ("angular",),
    mujoco.mjtJoint.mjJNT_SLIDE: ("linear",),
    mujoco.mjtJoint.mjJNT_BALL: ("rotX", "rotY", "rotZ"),
}


class SchemaMismatch(LookupError):
    """A PhysX API schema or property our code names that the registered PhysX schemas do not define."""


def registered() -> bool:
    """Whether USD's schema registry holds the PhysX schemas: installed, and registered before it was built."""
    return bool(Usd.SchemaRegistry().FindAppliedAPIPrimDefinition("PhysxSceneAPI"))


def missing_reason() -> str:
    """Why the PhysX schemas are not in USD's schema registry, in one line."""
    try:
        import physx_usd_schemas  # noqa: F401, PLC0415 -- only asks whether it is installed
    except ImportError:
        return f"physx-usd-schemas is not installed ({INSTALL})"
    return (
        "physx-usd-schemas was registered after USD built its schema registry (import joshua_usd's USD modules first)"
    )


@cache
def attribute_name(api: str, name: str, instance: str = "") -> str:
    """The full name of property `name` of the applied API schema `api` (of its `instance` where `api` is
    multiple-apply): from the schema's definition when registered (SchemaMismatch if it has none), else by the
    schemas' naming convention."""
    if not registered():
        namespace = api[0].lower() + api[1:].removesuffix("API")
        return ":".join(part for part in (namespace, instance, name) if part)
    definition = Usd.SchemaRegistry().FindAppliedAPIPrimDefinition(api)
    if not definition:
        raise SchemaMismatch(f"{api} is not an applied API schema of the PhysX schemas")
    multiple = Usd.SchemaRegistry.IsMultipleApplyAPISchema(api)
    if multiple != bool(instance):
        raise SchemaMismatch(f"{api} is {'multiple' if multiple else 'single'}-apply: instance {instance!r}")
    for template in definition.GetPropertyNames():
        if multiple and Usd.SchemaRegistry.GetMultipleApplyNameTemplateBaseName(template) == name:
            return Usd.SchemaRegistry.MakeMultipleApplyNameInstance(template, instance)
        if not multiple and template.rpartition(":")[2] == name:
            return template
    raise SchemaMismatch(f"{api} defines no property {name}")


def apply(prim: Usd.Prim, api: str, instance: str = "") -> None:
    """Apply the PhysX API schema `api` (its `instance` where multiple-apply) to `prim`, registered or not."""
    prim.AddAppliedSchema(f"{api}:{instance}" if instance else api)


def check_stage(stage: Usd.Stage) -> list[str]:
    """One line per problem, [] when none: a PhysX API schema applied that the PhysX schemas do not define as an
    applied API schema, and a physx* attribute authored that no applied PhysX API schema of its prim defines, or
    defines with another type. Needs the registered schemas (registered(); missing_reason() says why not)."""
    if not registered():
        raise SchemaMismatch(f"PhysX schemas not checked: {missing_reason()}")
    registry = Usd.SchemaRegistry()
    problems = []
    for prim in stage.TraverseAll():
        for applied in prim.GetPrimTypeInfo().GetAppliedAPISchemas():  # unknown ones too, unlike GetAppliedSchemas
            api = Usd.SchemaRegistry.GetTypeNameAndInstance(applied)[0]
            if api.lower().startswith(PREFIX) and not registry.FindAppliedAPIPrimDefinition(api):
                problems.append(f"{prim.GetPath()}: {api} is not an applied API schema of the PhysX schemas")
        definition = prim.GetPrimDefinition()
        for attribute in prim.GetAuthoredAttributes():
            name = attribute.GetName()
            if not name.startswith(PREFIX):
                continue
            defined = definition.GetAttributeDefinition(name)
            if not defined:
                problems.append(f"{prim.GetPath()}: {name} is not defined by an applied PhysX API schema")
            else:
                ours, theirs = _declared(attribute.GetPropertyStack()[0]), _declared(defined)
                if ours != theirs:
                    problems.append(f"{prim.GetPath()}: {name} is {ours}, the PhysX schema's is {theirs}")
    return problems


def _declared(attribute: Sdf.AttributeSpec | Usd.PrimDefinition.Attribute) -> str:
    """An attribute's type as usda declares it (`uniform token`, `float`): of a layer's own spec, since a composed
    attribute reports a registered schema's type and variability instead of what the layer says."""
    if isinstance(attribute, Sdf.AttributeSpec):
        type_name, variability = attribute.typeName, attribute.variability
    else:
        type_name, variability = attribute.GetTypeName(), attribute.GetVariability()
    return f"{'uniform ' if variability == Sdf.VariabilityUniform else ''}{type_name}"
