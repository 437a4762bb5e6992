"""The physics scene, the articulation root and one rigid body per MuJoCo body (world poses, mass)."""

from __future__ import annotations

import itertools

import mujoco
import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdPhysics

from joshua_usd.exporter.context import Context, set_physx, set_pose, set_raw
from joshua_usd.exporter.filtering import bits, can_touch
from joshua_usd.exporter.frames import gf_quatf, gf_vec3f

SCENE_PATH = Sdf.Path("/PhysicsScene")
OPTION_PREFIX = "joshua:option:"  # MuJoCo solver settings on the PhysicsScene


def write_scene(ctx: Context) -> None:
    """A PhysicsScene with MuJoCo's gravity and timestep (PhysX steps per second)."""
    scene = UsdPhysics.Scene.Define(ctx.stage, SCENE_PATH)
    gravity = np.asarray(ctx.model.opt.gravity, float)
    magnitude = float(np.linalg.norm(gravity))
    direction = gravity / magnitude if magnitude > 0 else np.array([0.0, 0.0, -1.0])
    scene.CreateGravityDirectionAttr(gf_vec3f(direction))
    scene.CreateGravityMagnitudeAttr(magnitude)
    prim = scene.GetPrim()
    steps = int(round(1.0 / ctx.model.opt.timestep))
    set_physx(prim, "PhysxSceneAPI", "timeStepsPerSecond", Sdf.ValueTypeNames.UInt, steps)
    _write_options(ctx, prim)


def _write_options(ctx: Context, prim: Usd.Prim) -> None:
    """MuJoCo's solver settings that PhysX has no attribute for and the trajectory depends on, as custom
    joshua:option:* attributes (Isaac ignores them; the importer restores them): integrator, friction cone
    (lower-case names without MuJoCo's prefix) and impratio."""
    option = ctx.model.opt
    integrator = mujoco.mjtIntegrator(option.integrator).name.removeprefix("mjINT_").lower()
    cone = mujoco.mjtCone(option.cone).name.removeprefix("mjCONE_").lower()
    set_raw(prim, f"{OPTION_PREFIX}integrator", Sdf.ValueTypeNames.Token, integrator, custom=True)
    set_raw(prim, f"{OPTION_PREFIX}cone", Sdf.ValueTypeNames.Token, cone, custom=True)
    set_raw(prim, f"{OPTION_PREFIX}impratio", Sdf.ValueTypeNames.Double, float(option.impratio), custom=True)


def write_root(ctx: Context) -> None:
    """The robot's root Xform: default prim, articulation root, PhysX self-collision flag."""
    prim = UsdGeom.Xform.Define(ctx.stage, ctx.root).GetPrim()
    ctx.stage.SetDefaultPrim(prim)
    UsdPhysics.ArticulationRootAPI.Apply(prim)
    self_collisions = self_collides(ctx.model)
    set_physx(prim, "PhysxArticulationAPI", "enabledSelfCollisions", Sdf.ValueTypeNames.Bool, self_collisions)


def self_collides(model: mujoco.MjModel) -> bool:
    """Whether two geoms of the robot on bodies MuJoCo does not filter (the same weld group, or
    parent and child) can touch by their contype/conaffinity bits."""
    weld = model.body_weldid
    geoms = [g for g in range(model.ngeom) if weld[model.geom_bodyid[g]] != 0]
    for a, b in itertools.combinations(geoms, 2):
        body_a, body_b = weld[model.geom_bodyid[a]], weld[model.geom_bodyid[b]]
        parent_a, parent_b = weld[model.body_parentid[body_a]], weld[model.body_parentid[body_b]]
        related = body_a == body_b or parent_a == body_b or parent_b == body_a
        if not related and can_touch(bits(model, a), bits(model, b)):
            return True
    return False


def write_bodies(ctx: Context) -> None:
    """One Xform per body, siblings under the root (rigid bodies must not nest), posed in the world at
    qpos0, with MuJoCo's mass, centre of mass and principal inertia."""
    model = ctx.model
    for body in range(1, model.nbody):
        path = ctx.child_path(ctx.root, ctx.name(mujoco.mjtObj.mjOBJ_BODY, body, "body"))
        ctx.body_paths[body] = path
        prim = UsdGeom.Xform.Define(ctx.stage, path).GetPrim()
        pose = ctx.body_pose(body)
        set_pose(prim, pose.pos, pose.quat)
        rigid = UsdPhysics.RigidBodyAPI.Apply(prim)
        if model.body_mocapid[body] >= 0:
            rigid.CreateKinematicEnabledAttr(True)
        mass = UsdPhysics.MassAPI.Apply(prim)
        mass.CreateMassAttr(float(model.body_mass[body]))
        mass.CreateCenterOfMassAttr(gf_vec3f(model.body_ipos[body]))
        mass.CreateDiagonalInertiaAttr(gf_vec3f(model.body_inertia[body]))
        mass.CreatePrincipalAxesAttr(gf_quatf(model.body_iquat[body]))
