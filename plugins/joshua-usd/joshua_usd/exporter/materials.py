"""Looks (UsdPreviewSurface from MuJoCo colours and materials) and physics materials (friction), one
prim per distinct value, bound to the geoms that use them."""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np
from pxr import Gf, Sdf, Usd, UsdPhysics, UsdShade

from joshua_usd.exporter.context import Context, set_physx

DEFAULT_SHININESS = 0.5  # MuJoCo's default material


@dataclass
class Materials:
    """Creates each material once (deterministic names, in order of first use) and binds them."""

    ctx: Context
    _looks: dict[object, UsdShade.Material] = field(default_factory=dict)
    _physics: dict[float, UsdShade.Material] = field(default_factory=dict)

    def bind_look(self, prim: Usd.Prim, geom: int) -> None:
        model = self.ctx.model
        matid = int(model.geom_matid[geom])
        rgba = model.mat_rgba[matid] if matid >= 0 else model.geom_rgba[geom]
        key = ("material", matid) if matid >= 0 else ("rgba", tuple(np.round(rgba, 6)))
        if key not in self._looks:
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_MATERIAL, matid) if matid >= 0 else "rgba"
            self._looks[key] = self._look(name or f"material{matid}", rgba, matid)
            if matid >= 0 and (model.mat_texid[matid] >= 0).any():
                self.ctx.note(f"material '{name}': textures are not exported")
        UsdShade.MaterialBindingAPI.Apply(prim).Bind(self._looks[key])

    def _look(self, name: str, rgba: np.ndarray, matid: int) -> UsdShade.Material:
        """A UsdPreviewSurface (metallic workflow): diffuseColor and opacity from rgba; metallic and
        roughness from MuJoCo 4's PBR values where set, else metallic 0 and roughness 1 - shininess;
        emissiveColor = emission * rgb."""
        model, stage = self.ctx.model, self.ctx.stage
        looks = self.ctx.scope("Looks")
        material = UsdShade.Material.Define(stage, self.ctx.child_path(looks, name))
        shader = UsdShade.Shader.Define(stage, material.GetPath().AppendChild("PreviewSurface"))
        shader.CreateIdAttr("UsdPreviewSurface")
        shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*(float(c) for c in rgba[:3])))
        shader.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(float(rgba[3]))
        metallic = model.mat_metallic[matid] if matid >= 0 else -1.0
        roughness = model.mat_roughness[matid] if matid >= 0 else -1.0
        shininess = model.mat_shininess[matid] if matid >= 0 else DEFAULT_SHININESS
        shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(float(max(metallic, 0.0)))
        shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(
            float(roughness if roughness >= 0 else 1.0 - shininess)
        )
        emission = model.mat_emission[matid] if matid >= 0 else 0.0
        if emission > 0:
            emissive = Gf.Vec3f(*(float(emission * c) for c in rgba[:3]))
            shader.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(emissive)
        material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
        return material

    def bind_friction(self, prim: Usd.Prim, geom: int) -> None:
        """MuJoCo's sliding friction as static and dynamic friction, combined by max as MuJoCo does."""
        friction = float(self.ctx.model.geom_friction[geom, 0])
        if friction not in self._physics:
            path = self.ctx.child_path(self.ctx.scope("PhysicsMaterials"), f"friction_{len(self._physics) + 1}")
            material = UsdShade.Material.Define(self.ctx.stage, path)
            api = UsdPhysics.MaterialAPI.Apply(material.GetPrim())
            api.CreateStaticFrictionAttr(friction)
            api.CreateDynamicFrictionAttr(friction)
            api.CreateRestitutionAttr(0.0)
            token = Sdf.ValueTypeNames.Token
            set_physx(material.GetPrim(), "PhysxMaterialAPI", "frictionCombineMode", token, "max", uniform=True)
            self._physics[friction] = material
        UsdShade.MaterialBindingAPI.Apply(prim).Bind(
            self._physics[friction], UsdShade.Tokens.weakerThanDescendants, "physics"
        )
