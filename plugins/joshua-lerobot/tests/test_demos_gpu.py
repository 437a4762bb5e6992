"""The GPU episode producer (joshua_lerobot.mjx_rollouts) on MuJoCo Warp, which runs on the CPU here (slowly: 2
environments, 32x24 frames; one whole attempt of 300 control steps, about 8 s after an 11 s compile): its rollouts
have the dataset's rows in the model's units, its frames show the cube where the simulation has it (at its start,
and at its goal once placed), and `joshua demos --physics gpu` writes a dataset the real lerobot loads."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import jax
import mujoco
import numpy as np
import pytest
from lerobot_harness import lerobot

from joshua_core.cli import main
from joshua_core.config import finalize, load_preset
from joshua_core.errors import UsageError
from joshua_core.options import LENIENT
from joshua_core.plugins import PluginHost
from joshua_lerobot.demos import gpu_physics_missing, make_producer
from joshua_lerobot.mjx_rollouts import ScriptedMjxProducer
from joshua_lerobot.rollouts import Rollout
from joshua_mujoco import PickPlaceScript

pytest.importorskip("mujoco_warp", reason="the GPU producer needs MJX-Warp: joshua-mjx[warp]")
pytestmark = pytest.mark.slow  # compiles and rolls out MuJoCo Warp on the CPU: about a minute on 2 busy cores

PRESET = "so_arm100_pick_place_mjx_dr"
SEED, NUM_ENVS, FPS, STRIDE = 0, 2, 25, 2  # 25 fps: every 2nd step of the 50 Hz task
WIDTH, HEIGHT = 32, 24
ROWS = 300 // STRIDE  # the script's 300 control steps
PIXEL_TOL = 1.5  # a 3 cm cube spans 2-3 pixels at 32x24


@pytest.fixture(scope="module")
def producer() -> ScriptedMjxProducer:
    training = finalize(load_preset(PRESET, LENIENT)).training
    made = ScriptedMjxProducer(
        num_envs=NUM_ENVS,
        cameras=["overview"],
        size=(WIDTH, HEIGHT),
        fps=FPS,
        seed=SEED,
        plugins=PluginHost.discover(),
        training=training,
    )
    yield made
    made.close()


@pytest.fixture(scope="module")
def attempts(producer: ScriptedMjxProducer) -> list[Rollout]:
    """The first batch: the first NUM_ENVS attempts."""
    stream = producer.rollouts()
    return [next(stream) for _ in range(NUM_ENVS)]


def first_reset(producer: ScriptedMjxProducer):
    """The environments' state at the start of the first batch (the producer's first draw from SEED)."""
    return producer.env.reset(jax.random.split(jax.random.PRNGKey(SEED))[1])


def project(model: mujoco.MjModel, camera: str, point: np.ndarray) -> np.ndarray:
    """(column, row) of a world point in `camera`'s WIDTH x HEIGHT image (pinhole, vertical field of view)."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    index = model.camera(camera).id
    local = data.cam_xmat[index].reshape(3, 3).T @ (point - data.cam_xpos[index])
    focal = HEIGHT / 2 / math.tan(math.radians(model.cam_fovy[index]) / 2)
    return np.array([WIDTH / 2 + focal * local[0] / -local[2] - 0.5, HEIGHT / 2 - focal * local[1] / -local[2] - 0.5])


def red_centre(image: np.ndarray) -> np.ndarray:
    """(column, row) centroid of the cube's red pixels (the arm is orange and yellow, the table brown)."""
    r, g, b = (image[..., channel].astype(int) for channel in range(3))
    rows, columns = np.nonzero((r > 100) & (r > 2 * g) & (r > 2 * b))
    assert rows.size, "no red pixel: the cube is not in the image"
    return np.array([columns.mean(), rows.mean()])


def test_rollouts_are_the_scripts_rows_in_the_models_units(
    producer: ScriptedMjxProducer, attempts: list[Rollout]
) -> None:
    assert producer.joint_names == tuple(f"joint_{i}" for i in range(1, 7)) and producer.stride == STRIDE
    start = first_reset(producer)
    qpos = np.asarray(start.data.qpos, dtype=np.float64)
    cube = producer.env.model.body("cube").id
    for i, attempt in enumerate(attempts):
        assert attempt.states.shape == attempt.actions.shape == (ROWS, 6)
        assert attempt.frames["overview"].shape == (ROWS, HEIGHT, WIDTH, 3)
        assert attempt.frames["overview"].dtype == np.uint8
        np.testing.assert_allclose(attempt.states[0], qpos[i, producer.qpos_addresses], atol=1e-6)  # radians
        # the first target is the CPU script's (no sag measured yet), in the joints' units
        script = PickPlaceScript(producer.env.model, producer.env.task)
        plan = script.actions(qpos[i], np.asarray(start.data.xpos[i, cube]), np.asarray(start.commands["goal"][i]))
        next(plan)
        np.testing.assert_allclose(attempt.actions[0], script.in_force, atol=1e-5)
        # the servos follow the targets: the arm ends where it was sent, within the sag the script takes out
        assert np.abs(attempt.states[-1, :5] - attempt.actions[-1, :5]).max() < 0.05
        assert np.abs(attempt.states[-1] - attempt.states[0]).max() > 0.3  # and it moved


def test_frames_show_the_cube_at_its_start_and_at_its_goal(
    producer: ScriptedMjxProducer, attempts: list[Rollout]
) -> None:
    start = first_reset(producer)
    model, cube = producer.env.model, producer.env.model.body("cube").id
    assert any(attempt.success for attempt in attempts)
    for i, attempt in enumerate(attempts):
        frames = attempt.frames["overview"]
        at_start = project(model, "overview", np.asarray(start.data.xpos[i, cube], dtype=np.float64))
        np.testing.assert_allclose(red_centre(frames[0]), at_start, atol=PIXEL_TOL)
        if attempt.success:  # placed: the cube's pixels are on the goal's
            at_goal = project(model, "overview", np.asarray(start.commands["goal"][i], dtype=np.float64))
            np.testing.assert_allclose(red_centre(frames[-1]), at_goal, atol=PIXEL_TOL)
            assert np.linalg.norm(at_goal - at_start) > 2 * PIXEL_TOL  # so the two checks differ


def test_demos_on_the_gpu_producer_load_in_lerobot(
    attempts: list[Rollout], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # in this process, where the producer's programs are compiled already (a subprocess spent 10-40 s redoing it)
    out = tmp_path / "demos"
    status = main(["demos", "--out", str(out), "--physics", "gpu", "--episodes", "1", "--num-envs", str(NUM_ENVS),
                   "--seed", str(SEED), "--fps", str(FPS), "--width", str(WIDTH), "--height", str(HEIGHT),
                   "--preset", PRESET])  # fmt: skip
    printed = capsys.readouterr()
    assert status == 0, printed.err[-3000:]
    assert "compiling the rollout" in printed.err and "1 of 1 attempts succeeded" in printed.out, printed
    on_the_cpu = "joshua: warning: --physics gpu: JAX finds no GPU here, so MuJoCo Warp runs on the CPU, far slower"
    assert (on_the_cpu in printed.err) == (jax.default_backend() != "gpu"), printed.err  # said, where it is so
    kept = next(attempt for attempt in attempts if attempt.success)  # the same seed: the same first attempt
    loaded = lerobot("delta", out, tmp_path)
    assert (loaded["frames"], loaded["episodes"], loaded["fps"]) == (ROWS, 1, FPS)
    (camera,) = loaded["cameras"].values()
    assert camera["shape"] == [2, 3, HEIGHT, WIDTH]  # each sample: the frame before and this one
    decoded = np.array(camera["mean"])[:, 1]  # this frame's mean brightness in [0, 1], through H.264
    assert np.allclose(decoded, kept.frames["overview"].reshape(ROWS, -1).mean(axis=1) / 255, rtol=0, atol=0.03)


def test_the_gpu_path_without_joshua_mjx_is_a_usage_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "joshua_mjx", None)  # as if joshua-mjx were not installed
    assert gpu_physics_missing() == "joshua-mjx"
    arguments = type("Arguments", (), {"physics": "gpu"})()
    with pytest.raises(UsageError, match=r"^--physics gpu needs joshua-mjx: pip install 'joshua-mjx\[warp\]'"):
        make_producer(arguments, finalize(load_preset(PRESET, LENIENT)).training, PluginHost.discover())
