"""The frame renderer: camera lookup, the renderer factory, commands drawn as markers, and the GL platform choice."""

from __future__ import annotations

import subprocess
import sys

import mujoco
import numpy as np
import pytest
from render_testing import SCENE, green_pixels, headless_env

from joshua_core.errors import UsageError
from joshua_render import camera_id, create_renderer, render_with_commands

# A grey floor seen from straight above by camera `top` (image right: +x, image up: +y), with a world site `goal`.
FLOOR = """
<mujoco>
  <worldbody>
    <light pos="0 0 3"/>
    <camera name="top" pos="0 0 1" xyaxes="1 0 0 0 1 0"/>
    <geom type="plane" size="1 1 0.1" rgba="0.5 0.5 0.5 1"/>
    <site name="goal" pos="0 0 0.01" size="0.03" rgba="1 0 0 1"/>
  </worldbody>
</mujoco>
"""


def test_camera_id_by_name_default_and_unknown() -> None:
    model = mujoco.MjModel.from_xml_path(str(SCENE))
    assert camera_id(model, None) == 0 and camera_id(model, "side") == model.camera("side").id
    no_cameras = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='1'/></worldbody></mujoco>")
    assert camera_id(no_cameras, None) == -1  # the free camera
    with pytest.raises(UsageError, match="no camera 'top' in the model; cameras: overview, side"):
        camera_id(model, "top")
    with pytest.raises(UsageError, match="cameras: none"):
        camera_id(no_cameras, "top")


def test_create_renderer_enlarges_the_offscreen_buffer() -> None:
    model = mujoco.MjModel.from_xml_string(FLOOR)
    renderer = create_renderer(model, 1000, 700)
    try:
        assert (model.vis.global_.offwidth, model.vis.global_.offheight) == (1000, 700)
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        renderer.update_scene(data, camera="top")
        assert renderer.render().shape == (700, 1000, 3)
    finally:
        renderer.close()


@pytest.mark.parametrize("size", [(0, 0), (160, 0), (20000, 20000)])
def test_a_size_without_pixels_or_beyond_the_framebuffer_is_one_line_naming_it(size: tuple[int, int]) -> None:
    """Not an empty image, nor "install EGL" for a platform that works: the size is at fault, and the model
    still renders at a size the platform has."""
    model = mujoco.MjModel.from_xml_path(str(SCENE))
    with pytest.raises(UsageError, match=f"^cannot render {size[0]}x{size[1]} images: ") as caught:
        create_renderer(model, *size)
    assert "\n" not in str(caught.value) and "install" not in str(caught.value)
    renderer = create_renderer(model, 32, 24)
    assert renderer.render().shape == (24, 32, 3)
    renderer.close()


def test_commands_are_drawn_as_green_spheres_and_move_the_site_named_like_them() -> None:
    model = mujoco.MjModel.from_xml_string(FLOOR)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    renderer = create_renderer(model, 320, 240)
    try:
        top = camera_id(model, "top")
        plain = render_with_commands(renderer, model, data, top, {})
        commands = {"goal": np.array([0.25, 0.2, 0.05]), "target": np.array([-0.25, -0.2, 0.05]), "scalar": np.ones(1)}
        drawn = render_with_commands(renderer, model, data, top, commands)
    finally:
        renderer.close()
    assert green_pixels(plain) == 0
    np.testing.assert_allclose(model.site_pos[model.site("goal").id], [0.25, 0.2, 0.01])  # x, y only
    upper_right, lower_left = drawn[:120, 160:], drawn[120:, :160]  # +x +y, and -x -y, seen from above
    assert green_pixels(upper_right) > 30 and green_pixels(lower_left) > 30
    assert green_pixels(drawn) == green_pixels(upper_right) + green_pixels(lower_left)  # nothing for `scalar`


RENDER_PROBE = f"""
import os
import numpy as np
{{first}}
from joshua_render import create_renderer
import mujoco
model = mujoco.MjModel.from_xml_path({str(SCENE)!r})
data = mujoco.MjData(model)
mujoco.mj_forward(model, data)
renderer = create_renderer(model, 96, 72)
renderer.update_scene(data)
image = renderer.render()
print(os.environ.get("MUJOCO_GL"), len(np.unique(image.reshape(-1, 3), axis=0)))
"""


def probe(first: str = "", **env: str) -> subprocess.CompletedProcess[str]:
    script = RENDER_PROBE.format(first=first)
    return subprocess.run(
        [sys.executable, "-c", script], env=headless_env(**env), capture_output=True, text=True, timeout=120
    )


def test_gl_platform_egl_by_default_osmesa_when_asked_or_when_egl_is_unusable() -> None:
    default = probe()
    assert default.returncode == 0, default.stderr
    platform, colours = default.stdout.split()
    assert platform == "egl" and int(colours) > 100
    asked = probe(MUJOCO_GL="osmesa")
    assert asked.returncode == 0, asked.stderr
    assert asked.stdout.split()[0] == "osmesa" and int(asked.stdout.split()[1]) > 100
    no_egl = probe(__EGL_VENDOR_LIBRARY_FILENAMES="/nonexistent/egl_vendor.json")  # glvnd finds no EGL driver
    assert no_egl.returncode == 0, no_egl.stderr
    assert no_egl.stdout.split()[0] == "osmesa" and int(no_egl.stdout.split()[1]) > 100


def test_rendering_works_when_mujoco_was_imported_first() -> None:
    """mujoco picked GLFW (no display to use) at its import; the chosen platform's context replaces it."""
    imported_first = probe(first="import mujoco")
    assert imported_first.returncode == 0, imported_first.stderr
    assert imported_first.stdout.split()[0] == "egl" and int(imported_first.stdout.split()[1]) > 100
