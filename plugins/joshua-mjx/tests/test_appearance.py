"""Appearance randomization (joshua_core.tasks.randomization: colour, camera pose, light) in the MJX environments'
images, rendered per environment by MuJoCo Warp on the CPU: images checked by their content.

The pick-and-place scene's overview camera at 32x32 in 2 environments, the cube at the same place in both. One
environment set draws all three events under a curriculum (its first episodes at strength 0), so each event's draw
at full strength is tried alone by giving a state those fields only.
"""

from __future__ import annotations

import copy

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from google.protobuf import text_format

from joshua_core.config_pb2 import TaskConfig
from joshua_core.interfaces import EnvSpec
from joshua_core.plugins import PluginHost
from joshua_mjx import MjxEnv, Physics
from joshua_mjx.env import mjx_envs

pytest.importorskip("mujoco_warp", reason="cameras need MJX-Warp: joshua-mjx[warp] (warp-lang, mujoco-warp)")

TASK = "so_arm100_pick_place"
SIZE = 32
CAMERA = f'cameras {{ camera: "overview" width: {SIZE} height: {SIZE} }}'
EVENTS = """
events { name: "colour" term: "randomize_geom_rgba" mode: RESET params { key: "geoms" value: "cube" }
         params { key: "operation" value: "set" } params { key: "red" value: "[0.0, 0.05]" }
         params { key: "green" value: "[0.3, 1.0]" } params { key: "blue" value: "[0.0, 0.05]" } }
events { name: "pose" term: "randomize_camera_pose" mode: RESET params { key: "cameras" value: "overview" }
         params { key: "position" value: "[-0.03, 0.03]" } params { key: "rotation" value: "[-0.15, 0.15]" } }
events { name: "light" term: "randomize_light" mode: RESET params { key: "lights" value: '["key", "fill"]' }
         params { key: "direction" value: "[-0.2, 0.2]" } params { key: "diffuse" value: "[0.1, 0.4]" } }
terms { name: "always" term: "alive" kind: METRIC }
randomization_curriculum { metric: "always" start: 0 }
"""
CUBE = np.array([0.3, 0.0, 0.015])  # the cube's centre on the table, in both environments
PIXEL_TOL = 1.5  # pixels: a 3 cm cube spans about 2-3 pixels at 32x32
RATIO_TOL = 0.1  # relative: the green of the cube's pixels against its drawn green (specular light adds some)


def _envs(config: str) -> MjxEnv:
    spec = EnvSpec(TASK, 2, task_config=text_format.Parse(config, TaskConfig()), curriculum=True)
    return mjx_envs(spec, PluginHost.discover(), Physics("warp"))


@pytest.fixture(scope="module")
def plain() -> MjxEnv:
    return _envs(CAMERA)


@pytest.fixture(scope="module")
def randomized() -> MjxEnv:
    return _envs(CAMERA + EVENTS)


def _at_cube(env: MjxEnv, state, params: dict | None = None):
    """The state one step after putting the cube at rest at CUBE in every environment (with `params`)."""
    address = env.model.jnt_qposadr[env.model.joint("cube_joint").id]
    qpos = np.array(state.data.qpos)
    qpos[:, address : address + 7] = np.concatenate([CUBE, [1.0, 0, 0, 0]])
    data = state.data.replace(qpos=jnp.asarray(qpos), qvel=jnp.zeros_like(state.data.qvel))
    state = state._replace(data=data, params=state.params if params is None else params)
    return env.step(state, jnp.zeros((2, env.action_size)))


def _project(model: mujoco.MjModel, point: np.ndarray) -> np.ndarray:
    """(column, row) of a world point in the overview camera's SIZE x SIZE image (pinhole, rows top first)."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    index = model.camera("overview").id
    local = data.cam_xmat[index].reshape(3, 3).T @ (point - data.cam_xpos[index])
    focal = SIZE / 2 / np.tan(np.radians(model.cam_fovy[index]) / 2)
    return np.array([SIZE / 2 - focal * local[0] / local[2] - 0.5, SIZE / 2 + focal * local[1] / local[2] - 0.5])


def _centre(mask: np.ndarray) -> np.ndarray:
    rows, columns = np.nonzero(mask)
    assert rows.size, "the cube is not in the image"
    return np.array([columns.mean(), rows.mean()])


def _red(image: np.ndarray) -> np.ndarray:
    r, g, b = (image[..., channel].astype(int) for channel in range(3))
    return (r > 100) & (r > 2 * g) & (r > 2 * b)


def _drawn(env: MjxEnv, state, names: tuple[str, ...]) -> dict:
    """The current params with `names` from a draw of all events at full strength."""
    drawn = env.redraw_starts(state._replace(strength=jnp.ones_like(state.strength))).start_params
    return {**state.params, **{name: drawn[name] for name in names}}


@pytest.mark.slow
def test_at_strength_zero_the_images_are_the_unrandomized_ones(plain: MjxEnv, randomized: MjxEnv) -> None:
    key = jax.random.PRNGKey(0)
    state, reference = randomized.reset(key), plain.reset(key)
    assert np.asarray(state.strength).tolist() == [0.0, 0.0]
    np.testing.assert_array_equal(np.asarray(state.images["overview"]), np.asarray(reference.images["overview"]))
    stepped, plain_stepped = _at_cube(randomized, state), _at_cube(plain, reference)
    np.testing.assert_array_equal(np.asarray(stepped.images["overview"]), np.asarray(plain_stepped.images["overview"]))


def test_colour_event_recolours_the_cube_in_each_environment(randomized: MjxEnv) -> None:
    state = randomized.reset(jax.random.PRNGKey(1))
    base = np.asarray(_at_cube(randomized, state).images["overview"])
    params = _drawn(randomized, state, ("geom_rgba",))
    cube = randomized.model.geom("cube").id
    rgba = np.asarray(params["geom_rgba"])[:, cube]
    assert np.all((rgba[:, 1] >= 0.3) & (rgba[:, 1] <= 1.0) & (rgba[:, [0, 2]] <= 0.05))
    images = np.asarray(_at_cube(randomized, state, params).images["overview"]).astype(int)
    cube_pixels = _red(base[0])
    assert cube_pixels.any() and not _red(images).any()  # the red cube is gone from both environments
    greens = []
    for image in images:
        r, g, b = (image[..., channel][cube_pixels] for channel in range(3))
        assert np.all(g > 2 * r) and np.all(g > 2 * b)
        greens.append((g - r).mean())  # what the specular light adds to every channel taken off
    assert greens[0] / greens[1] == pytest.approx(rgba[0, 1] / rgba[1, 1], rel=RATIO_TOL)


def test_camera_pose_event_moves_the_cube_in_the_image(randomized: MjxEnv) -> None:
    state = randomized.reset(jax.random.PRNGKey(2))
    base = _centre(_red(np.asarray(_at_cube(randomized, state).images["overview"])[0]))
    params = _drawn(randomized, state, ("cam_pos", "cam_quat"))
    images = np.asarray(_at_cube(randomized, state, params).images["overview"])
    camera = randomized.model.camera("overview").id
    moved = []
    for env, image in enumerate(images):
        model = copy.copy(randomized.model)
        model.cam_pos[camera] = np.asarray(params["cam_pos"])[env, camera]
        model.cam_quat[camera] = np.asarray(params["cam_quat"])[env, camera]
        centre = _centre(_red(image))
        np.testing.assert_allclose(centre, _project(model, CUBE), atol=PIXEL_TOL)
        moved.append(np.linalg.norm(centre - base))
    assert max(moved) > 2.0


def test_light_event_changes_the_brightness(randomized: MjxEnv) -> None:
    state = randomized.reset(jax.random.PRNGKey(3))
    base = np.asarray(_at_cube(randomized, state).images["overview"]).astype(float)
    params = _drawn(randomized, state, ("light_pos", "light_dir", "light_diffuse"))
    images = np.asarray(_at_cube(randomized, state, params).images["overview"]).astype(float)
    key = randomized.model.light("key").id
    factors = np.asarray(params["light_diffuse"])[:, key, 0] / randomized.model.light_diffuse[key, 0]
    assert np.all((factors >= 0.1) & (factors <= 0.4))
    means, base_means = images.mean(axis=(1, 2, 3)), base.mean(axis=(1, 2, 3))
    assert np.all(means < base_means - 5.0)  # the lights at 10-40 % of their diffuse: a darker image
