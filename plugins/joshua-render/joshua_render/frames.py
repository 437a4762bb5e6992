"""Headless frames of a MuJoCo model: the renderer factory, camera lookup, and 3-d commands drawn as markers.

Used by every plugin that renders (the MuJoCo backend's engines and environments, the modes, the
trainers' videos), so that a renderer is made and a camera named the same way everywhere.
"""

from __future__ import annotations

from collections.abc import Mapping

from joshua_render.gl import check_rendering, choose_headless_gl, rendering_unavailable

choose_headless_gl()  # must run before mujoco is imported: mujoco picks its GL platform at import

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from numpy.typing import NDArray  # noqa: E402

from joshua_core.errors import UsageError  # noqa: E402

MARKER_RGBA = np.array([0.1, 0.9, 0.2, 0.7], dtype=np.float32)  # the green spheres drawn at commands
MARKER_RADIUS = 0.02  # m
FRAMEBUFFER_INCOMPLETE = "Offscreen framebuffer is not complete"  # mjr_makeContext's error for a size beyond GL's


def camera_id(model: mujoco.MjModel, camera: str | None) -> int:
    """Id of the named camera; None: the model's first camera, or -1 (the free camera) if it has none."""
    if not camera:
        return 0 if model.ncam else -1
    found = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
    if found < 0:
        names = [model.camera(i).name for i in range(model.ncam)]
        raise UsageError(f"no camera '{camera}' in the model; cameras: {', '.join(names) or 'none'}")
    return found


def create_renderer(model: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
    """A headless `mujoco.Renderer` of `width` x `height`, enlarging the model's offscreen buffer if needed.

    A size below one pixel, or one the GL platform has no framebuffer for, is a one-line UsageError naming the
    size; a GL platform that cannot create a context raises `RenderingUnavailableError` naming what to install (at
    once where that is known already: an unknown MUJOCO_GL, a missing library, an earlier failure).
    """
    if width < 1 or height < 1:
        raise UsageError(f"cannot render {width}x{height} images: width and height must be at least 1 pixel")
    check_rendering()
    visual = model.vis.global_
    earlier = visual.offwidth, visual.offheight
    visual.offwidth = max(visual.offwidth, width)
    visual.offheight = max(visual.offheight, height)
    try:
        return mujoco.Renderer(model, height=height, width=width)
    except Exception as error:  # GL platform failures surface as several exception types
        visual.offwidth, visual.offheight = earlier  # the model stays usable at sizes the platform has
        if FRAMEBUFFER_INCOMPLETE in str(error):  # a context was made, but no framebuffer of this size
            raise UsageError(
                f"cannot render {width}x{height} images: the GL platform has no offscreen framebuffer that large "
                f"({error}); choose a smaller render_width/render_height"
            ) from None
        raise rendering_unavailable(error) from error


def render_with_commands(
    renderer: mujoco.Renderer,
    model: mujoco.MjModel,
    data: mujoco.MjData,
    camera: int,
    commands: Mapping[str, NDArray[np.float64]],
) -> NDArray[np.uint8]:
    """Render `data` (kinematics computed) with one environment's 3-d commands (targets, goals) as green spheres.

    A site of the world body named like a command (pick-and-place's `goal`) is moved to the command's
    x, y, so that the model's own marker shows the sampled goal.
    """
    for name, value in commands.items():
        site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name)
        if site >= 0 and model.site_bodyid[site] == 0 and np.shape(value) == (3,):
            model.site_pos[site, :2] = value[:2]
    renderer.update_scene(data, camera=camera)
    scene = renderer.scene
    for value in commands.values():
        if np.shape(value) == (3,) and scene.ngeom < scene.maxgeom:
            mujoco.mjv_initGeom(
                scene.geoms[scene.ngeom],
                mujoco.mjtGeom.mjGEOM_SPHERE,
                np.array([MARKER_RADIUS, 0.0, 0.0]),
                np.asarray(value, dtype=np.float64),
                np.eye(3).flatten(),
                MARKER_RGBA,
            )
            scene.ngeom += 1
    return renderer.render()
