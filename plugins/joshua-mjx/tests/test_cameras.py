"""Cameras as observations of the MJX environments (joshua_mjx.cameras): images checked by their content.

MuJoCo Warp renders on the CPU here (its kernels compile for the CPU; the first run fills Warp's kernel cache).
The pick-and-place scene at 32x32 in 2 environments: the cube is put at a different place in each, and the cube's
red pixels must lie where the camera's pinhole model projects the cube's centre (within PIXEL_TOL pixels), its depth
must be the planar distance of the cube's face towards the camera (within DEPTH_TOL metres), larger where the cube
is farther. The depth camera renders every 2nd step and holds its frame in between.
"""

from __future__ import annotations

import dataclasses
import math
import re

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from google.protobuf import text_format

from joshua_core.config_pb2 import TaskConfig
from joshua_core.errors import ConfigError
from joshua_core.plugins import PluginHost
from joshua_core.tasks import CameraSpec, build_task, load_task_spec
from joshua_mjx import MjxEnv, Physics, make_mjx_env

pytest.importorskip("mujoco_warp", reason="cameras need MJX-Warp: joshua-mjx[warp] (warp-lang, mujoco-warp)")

TASK = "so_arm100_pick_place"
SIZE = 32
CAMERAS = f"""
cameras {{ camera: "overview" width: {SIZE} height: {SIZE} }}
cameras {{ camera: "side" width: {SIZE} height: {SIZE} kind: DEPTH every_steps: 2 }}
"""
# cube centres on the table (x, y, z) in each environment: env 1's lies 0.2 m farther from the side camera (-y)
CUBES = np.array([[0.3, 0.12, 0.015], [0.3, -0.08, 0.015]])
CUBE_HALF = 0.015  # the cube's half size (pick_place_objects.xml)
PIXEL_TOL = 1.5  # pixels: a 3 cm cube spans about 2-3 pixels at 32x32
DEPTH_TOL = 0.01  # metres


@pytest.fixture(scope="module")
def env() -> MjxEnv:
    return make_mjx_env(TASK, 2, task_config=text_format.Parse(CAMERAS, TaskConfig()), physics=Physics("warp"))


def _project(model: mujoco.MjModel, camera: str, point: np.ndarray) -> tuple[float, float, float]:
    """(column, row, planar depth) of a world point in `camera`'s SIZE x SIZE image (pinhole, rows top first)."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    index = model.camera(camera).id
    local = data.cam_xmat[index].reshape(3, 3).T @ (point - data.cam_xpos[index])
    depth = -local[2]  # a camera looks along its -z axis
    focal = SIZE / 2 / math.tan(math.radians(model.cam_fovy[index]) / 2)
    return SIZE / 2 + focal * local[0] / depth - 0.5, SIZE / 2 - focal * local[1] / depth - 0.5, depth


def _red_centre(image: np.ndarray) -> np.ndarray:
    """(column, row) centroid of the cube's red pixels in an rgb image (H, W, 3): red well above green and blue
    (the arm is orange and yellow, the table brown)."""
    r, g, b = (image[..., channel].astype(int) for channel in range(3))
    rows, columns = np.nonzero((r > 100) & (r > 2 * g) & (r > 2 * b))
    assert rows.size, "no red pixel: the cube is not in the image"
    return np.array([columns.mean(), rows.mean()])


def _with_cubes(env: MjxEnv, state, cubes: np.ndarray):
    """`state` with the cube of each environment at rest at `cubes` (N, 3), upright."""
    address = env.model.jnt_qposadr[env.model.joint("cube_joint").id]
    qpos = np.array(state.data.qpos)
    qpos[:, address : address + 7] = np.concatenate([cubes, np.tile([1.0, 0, 0, 0], (len(cubes), 1))], axis=1)
    data = state.data.replace(qpos=jnp.asarray(qpos), qvel=jnp.zeros_like(state.data.qvel))
    return state._replace(data=data)


def test_images_follow_the_cube(env: MjxEnv) -> None:
    state = env.reset(jax.random.PRNGKey(0))
    assert state.images["overview"].shape == (2, SIZE, SIZE, 3) and state.images["overview"].dtype == jnp.uint8
    assert state.images["side"].shape == (2, SIZE, SIZE, 1) and state.images["side"].dtype == jnp.float32
    assert env.cameras.bytes_per_env == SIZE * SIZE * (3 + 4)
    held = np.asarray(state.images["side"])
    zero = jnp.zeros((2, env.action_size))
    state = env.step(_with_cubes(env, state, CUBES), zero)
    overview = np.asarray(state.images["overview"])
    for image, cube in zip(overview, CUBES, strict=True):
        column, row, _ = _project(env.model, "overview", cube)
        np.testing.assert_allclose(_red_centre(image), [column, row], atol=PIXEL_TOL)
    # the depth camera renders every 2nd step: after one step it holds the reset's frame, with the cubes elsewhere
    np.testing.assert_array_equal(np.asarray(state.images["side"]), held)
    state = env.step(state, zero)
    side = np.asarray(state.images["side"])[..., 0]
    depths = []
    for image, cube in zip(side, CUBES, strict=True):
        column, row, depth = _project(env.model, "side", cube)
        seen = image[round(row), round(column)]
        depths.append(seen)
        # the face towards the camera is CUBE_HALF nearer than the centre (the camera looks nearly level, along -y)
        assert seen == pytest.approx(depth - CUBE_HALF, abs=DEPTH_TOL)
    assert depths[1] - depths[0] == pytest.approx(0.2 * 0.996, abs=DEPTH_TOL)  # 0.2 m farther along the view


def test_config_errors_are_one_line(env: MjxEnv) -> None:
    plugins = PluginHost.discover()
    spec = load_task_spec(TASK, plugins)
    for cameras, message in (
        ('cameras { camera: "overveiw" }', "no camera named 'overveiw'. Did you mean: overview? Its cameras: "),
        ('cameras { camera: "side" width: -2 }', "width and height must be at least 1 pixel, got -2x64"),
        ('cameras { camera: "side" every_steps: -1 }', "every_steps must be at least 1"),
        ('cameras { camera: "side" } cameras { camera: "side" kind: DEPTH }', "named more than once"),
    ):
        with pytest.raises(ConfigError, match=re.escape(message)) as error:
            build_task(spec, env.model, plugins, text_format.Parse(cameras, TaskConfig()))
        assert "\n" not in str(error.value)
    with pytest.raises(ConfigError, match="kind must be one of rgb, depth, segmentation, got 'infrared'"):
        build_task(dataclasses.replace(spec, cameras=(CameraSpec("side", kind="infrared"),)), env.model, plugins)


def test_cameras_need_warp() -> None:
    with pytest.raises(ConfigError, match=r"renders cameras \(side\): that needs MuJoCo Warp's renderer"):
        make_mjx_env(TASK, 2, task_config=text_format.Parse('cameras { camera: "side" }', TaskConfig()))
