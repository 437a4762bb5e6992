"""A task's cameras (joshua_core.tasks.cameras) rendered for every environment inside the compiled step, with
MuJoCo Warp's batched ray tracer through MJX: `mjx.create_render_context` (model, nworld, the active cameras with
their sizes and outputs), then `mjx.refit_bvh` and `mjx.render` / `mjx.render_with_segmentation` on the batch of
Data. That renderer exists only for MuJoCo Warp, so cameras need `training.mjx { impl: WARP }`.

Cameras that render on the same steps (`every`) share one render context and one render call. A render context
holds Warp buffers sized for its number of worlds, so it serves batches of exactly `num_envs` environments.

Memory: the images kept in the EnvState are the current frame only, `bytes_per_env` per environment (H x W x 3
bytes for rgb, H x W x 4 for depth and segmentation). While rendering, Warp's packed outputs take 4 bytes per
pixel for rgb and depth and 8 for segmentation, per environment, and each render context a scene BVH per world.
"""

from __future__ import annotations

import math
from typing import Any

import jax
import jax.numpy as jnp
import mujoco

from joshua_core.errors import ConfigError
from joshua_core.tasks import Camera
from joshua_mjx.impl import WARP, Physics
from joshua_mjx.physics import mjx

# The scene's geom groups MuJoCo's viewer shows by default (0-2): collision-only geoms sit in group 3
_VISIBLE_GROUPS = [0, 1, 2]


class Cameras:
    """The render contexts of a task's cameras for `num_envs` environments; `render` and `update` run inside jit.

    `every` of each camera: it renders on the environment steps whose count (since reset, the same in every
    environment: `EnvState.camera_step`) is a multiple of it, and holds its last frame in between."""

    def __init__(self, task: str, cameras: tuple[Camera, ...], model: mujoco.MjModel, num_envs: int, physics: Physics):
        if physics.impl != WARP:
            names = ", ".join(camera.name for camera in cameras)
            raise ConfigError(
                f"task '{task}' renders cameras ({names}): that needs MuJoCo Warp's renderer, training.mjx.impl WARP"
            )
        self.cameras = cameras
        self.period = math.lcm(*(camera.every for camera in cameras))  # camera_step counts modulo this
        self._groups: dict[int, tuple[Any, tuple[Camera, ...]]] = {}
        for every in sorted({camera.every for camera in cameras}):
            members = tuple(camera for camera in cameras if camera.every == every)
            self._groups[every] = (_render_context(model, num_envs, members), members)

    @property
    def bytes_per_env(self) -> int:
        """Bytes of one environment's images in the EnvState (the current frame of every camera)."""
        return sum(camera.bytes_per_env for camera in self.cameras)

    def render(self, physics: Any, data: Any) -> tuple[dict[str, jax.Array], Any]:
        """Every camera's image of the batch `data`, by camera name, and the Data carrying Warp's execution token.
        `physics(function, data)` applies `function(model, data)` to every environment (MjxEnv._physics)."""
        images: dict[str, jax.Array] = {}
        for context, members in self._groups.values():
            frames, data = self._frames(physics, data, context, members)
            images.update(frames)
        return images, data

    def update(
        self, physics: Any, data: Any, camera_step: jax.Array, held: dict[str, jax.Array]
    ) -> tuple[dict[str, jax.Array], Any]:
        """The images after a step whose count is `camera_step` (N,): a fresh frame of each camera due then, the
        `held` one of the others. The count is the same in every environment, so one branch runs for the batch."""
        images: dict[str, jax.Array] = {}
        for every, (context, members) in self._groups.items():
            if every == 1:
                frames, data = self._frames(physics, data, context, members)
            else:
                kept = {camera.name: held[camera.name] for camera in members}
                frames, data = jax.lax.cond(
                    camera_step[0] % every == 0,
                    lambda d, c=context, m=members: self._frames(physics, d, c, m),
                    lambda d, kept=kept: (kept, d),
                    data,
                )
            images.update(frames)
        return images, data

    def _frames(
        self, physics: Any, data: Any, context: Any, members: tuple[Camera, ...]
    ) -> tuple[dict[str, jax.Array], Any]:
        """Render one context's cameras for the batch and unpack each camera's image."""
        handle = context.pytree()
        segmentation = any(camera.kind == "segmentation" for camera in members)

        def frame(model: Any, d: Any) -> tuple[jax.Array, jax.Array, jax.Array, Any]:
            d = mjx.refit_bvh(model, d, handle)
            if segmentation:
                return mjx.render_with_segmentation(model, d, handle)
            rgb, depth, d = mjx.render(model, d, handle)
            return rgb, depth, jnp.zeros((0, 2), jnp.int32), d

        with jax.named_scope("render"):
            rgb, depth, seg, data = physics(frame, data)
        images = {}
        for index, camera in enumerate(members):
            if camera.kind == "rgb":
                images[camera.name] = _unpack_rgb(_pixels(rgb, int(context.rgb_adr.numpy()[index]), camera))
            elif camera.kind == "depth":
                images[camera.name] = _pixels(depth, int(context.depth_adr.numpy()[index]), camera)[..., None]
            else:
                images[camera.name] = _pixels(seg[..., 0], int(context.seg_adr.numpy()[index]), camera)[..., None]
        return images, data


def _render_context(model: mujoco.MjModel, num_envs: int, cameras: tuple[Camera, ...]) -> Any:
    """A render context of `cameras` for `num_envs` worlds, each camera with its size and only its kind's output.
    Textures on (the scene's materials), shadows off (they cost a ray per light and pixel)."""
    return mjx.create_render_context(
        mjm=model,
        nworld=num_envs,
        cam_active=[camera.id for camera in cameras],
        cam_res=[(camera.width, camera.height) for camera in cameras],
        render_rgb=[camera.kind == "rgb" for camera in cameras],
        render_depth=[camera.kind == "depth" for camera in cameras],
        render_seg=[camera.kind == "segmentation" for camera in cameras],
        use_textures=True,
        use_shadows=False,
        enabled_geom_groups=_VISIBLE_GROUPS,
    )


def _pixels(packed: jax.Array, address: int, camera: Camera) -> jax.Array:
    """One camera's pixels (N, height, width) from a packed output (N, pixels of all cameras), rows top first."""
    size = camera.width * camera.height
    return packed[:, address : address + size].reshape(packed.shape[0], camera.height, camera.width)


def _unpack_rgb(packed: jax.Array) -> jax.Array:
    """uint8 (..., 3) red, green, blue of Warp's packed pixels (uint32, blue in the low byte: mjx.get_rgb)."""
    shifts = jnp.asarray([16, 8, 0], jnp.uint32)
    return ((packed[..., None] >> shifts) & 0xFF).astype(jnp.uint8)
