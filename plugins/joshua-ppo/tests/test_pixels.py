"""A pixel policy (training.ppo.pixels): PPO trains a policy that sees a camera image, the arm's joint readings and
its goal through a CNN encoder, beside a value network of the flat state; its checkpoint evaluates; it learns beside
a teacher of the flat observation (training.ppo.teacher); bad options are one-line ConfigErrors.

MuJoCo Warp renders on the CPU here: pick-and-place with one 16x16 rgb camera, 4 environments, 2 iterations of
4 steps, episodes of 20 steps.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import jax
import numpy as np
import pytest
from flax.serialization import from_bytes
from google.protobuf import text_format

from joshua_core.config import finalize, load_preset
from joshua_core.config_pb2 import TaskConfig, TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.interfaces import EnvKind
from joshua_core.options import options_of, parse_dict
from joshua_core.plugins import PluginHost
from joshua_core.run_context import RunContext
from joshua_mjx import MjxEnv, Physics, make_mjx_env
from joshua_ppo import options_pb2, train_mjx
from joshua_ppo.config_settings import PpoSettings, ppo_settings
from joshua_ppo.export import mlp_policy
from joshua_ppo.iteration import make_iteration
from joshua_ppo.normalizer import RunningStatistics
from joshua_ppo.policy import image_bytes_per_env, init_params, make_network, policy_actions
from joshua_ppo.settings import OptimizationSettings, ReturnSettings, RolloutSettings
from joshua_ppo.state import init_state
from joshua_ppo.teacher import load_teacher
from joshua_ppo.trainer import PpoTrainer

pytest.importorskip("mujoco_warp", reason="cameras need MJX-Warp: joshua-mjx[warp] (warp-lang, mujoco-warp)")
pytestmark = pytest.mark.slow  # trains and renders with Warp on the CPU

TASK = "so_arm100_pick_place"
SIZE = 16
NUM_ENVS, NUM_STEPS = 4, 4
PIXELS = {
    "cameras": ["overview"],
    "observation_terms": ["joint_pos"],
    "commands": ["goal"],
    "channels": [4, 8],
    "kernel_sizes": [3, 3],
    "strides": [2, 2],
    "feature_size": 16,
}
CONFIG = {
    "task": TASK,
    "num_envs": NUM_ENVS,
    "num_steps": NUM_STEPS,
    "num_epochs": 1,
    "minibatch_size": 8,
    "total_timesteps": 2 * NUM_ENVS * NUM_STEPS,  # 2 iterations
    "seed": 0,
    "mjx": {"impl": "WARP"},
    "task_config": {"episode_length": 20, "cameras": [{"camera": "overview", "width": SIZE, "height": SIZE}]},
    "run_name": "pixels",
    "hidden_sizes": [16],
    "checkpoint_interval": 2 * NUM_ENVS * NUM_STEPS,
    "ppo": {"value_hidden_sizes": [16], "video_interval": -1, "pixels": PIXELS},
}
JOINTS = 6  # joint_pos: the arm's six joints
GOAL = 3  # the goal command: a position


@pytest.fixture(scope="module")
def pixel_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("pixels")
    return train_mjx(model_path="so_arm100/pick_place_mjx.xml", config=CONFIG, checkpoint_dir=root)


@pytest.fixture(scope="module")
def env() -> MjxEnv:
    cameras = text_format.Parse(f'cameras {{ camera: "overview" width: {SIZE} height: {SIZE} }}', TaskConfig())
    return make_mjx_env(TASK, 2, task_config=cameras, physics=Physics("warp"))


def _settings(training: dict[str, Any]) -> PpoSettings:
    """The PPO settings of the training config `training` (a dict, as config.json holds it)."""
    config = TrainingConfig()
    parse_dict(training, config, PluginHost.discover().options())
    return ppo_settings(options_of(config, options_pb2.ppo), config)


@pytest.fixture(scope="module")
def teacher_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A policy of the flat observation (no cameras), 2 iterations at a high learning rate: a teacher unlike the
    student's fresh policy."""
    config = copy.deepcopy(CONFIG) | {"learning_rate": 1e-2}
    del config["task_config"]["cameras"], config["ppo"]["pixels"]
    config["task_config"]["episode_length"] = NUM_STEPS  # episodes end, so its history records a return and success
    config["run_name"] = "teacher"
    root = tmp_path_factory.mktemp("teacher")
    return train_mjx(model_path="so_arm100/pick_place_mjx.xml", config=config, checkpoint_dir=root)


def test_a_pixel_policy_trains_beside_its_teacher(
    teacher_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The teacher's imitation term (the KL from its action distribution, on the student's rollouts) enters the
    loss with its weight, in every minibatch; the run's log names the teacher and how far it had learned."""
    weight = 10.0
    config = copy.deepcopy(CONFIG)
    config["run_name"] = "student"
    config["ppo"]["teacher"] = {"run": str(teacher_run.parent / "teacher"), "weight": weight}
    train_mjx(model_path="so_arm100/pick_place_mjx.xml", config=config, checkpoint_dir=tmp_path)
    taught = json.loads((teacher_run / "metrics.json").read_text())["history"][-1]
    assert (
        f"ppo: imitating the teacher {teacher_run} ({taught['step']:,} env steps; its last iteration: mean return "
        f"{taught['mean_return']:.4g}, success {taught['metrics/success']:.3f})"
    ) in capsys.readouterr().out
    history = json.loads((tmp_path / "student" / "metrics.json").read_text())["history"]
    optimization = _settings(config).optimization
    assert len(history) == 2
    for record in history:
        assert np.isfinite(record["teacher_kl"]) and record["teacher_kl"] > 1e-3, record  # the policies differ
        ppo = record["policy_loss"] + optimization.value_coef * record["value_loss"]
        ppo -= optimization.entropy_coef * record["entropy"]
        assert record["loss"] == pytest.approx(ppo + weight * record["teacher_kl"], rel=1e-4), record


def test_a_teacher_must_see_the_flat_observation_of_the_same_task(pixel_run: Path, env: MjxEnv) -> None:
    context, network = RunContext(PluginHost.discover(), pixel_run), _settings(CONFIG).network
    teacher = _settings({"ppo": {"teacher": {"run": str(pixel_run)}}}).teacher
    assert teacher is not None and teacher.weight == 1.0  # the default weight
    with pytest.raises(ConfigError, match="a policy that sees camera images; the teacher must see the flat"):
        load_teacher(teacher, env, TASK, context, network)
    with pytest.raises(ConfigError, match="a policy of task 'so_arm100_pick_place', not 'so_arm100_reach'"):
        load_teacher(teacher, env, "so_arm100_reach", context, network)
    with pytest.raises(ConfigError, match="teacher.run must name"):
        _settings({"ppo": {"teacher": {"weight": 2.0}}})
    with pytest.raises(ConfigError, match="teacher.weight must not be negative"):
        _settings({"ppo": {"teacher": {"run": "runs/x", "weight": -1.0}}})


def test_a_pixel_run_trains_a_conv_encoder_and_states_its_image_memory(pixel_run: Path) -> None:
    params = from_bytes(None, (pixel_run / "params.msgpack").read_bytes())["params"]
    encoder = params["encoder_overview"]
    assert np.shape(encoder["Conv_0"]["kernel"]) == (3, 3, 3, 4)  # rgb in, 4 channels out
    assert np.shape(encoder["Conv_1"]["kernel"]) == (3, 3, 4, 8)
    # SAME padding, stride 2 twice: 16 -> 8 -> 4 pixels a side, 8 channels, into 16 features
    assert np.shape(encoder["Dense_0"]["kernel"]) == (4 * 4 * 8, 16)
    # the policy sees the image's features, the joint readings and the goal; the value network the flat observation
    assert np.shape(params["policy"]["Dense_0"]["kernel"]) == (16 + JOINTS + GOAL, 16)
    run = pixel_run.parent / "pixels"
    document = json.loads((run / "config.json").read_text())
    assert document["rollout_image_bytes"] == NUM_STEPS * NUM_ENVS * SIZE * SIZE * 3
    assert np.shape(params["value"]["Dense_0"]["kernel"]) == (document["observation_size"], 16)
    history = json.loads((run / "metrics.json").read_text())["history"]
    assert len(history) == 2 and all(np.isfinite(record["value_loss"]) for record in history), history
    assert all(np.isfinite(np.asarray(leaf)).all() for leaf in jax.tree.leaves(params))


def test_the_policy_action_follows_the_image_not_the_unseen_state(pixel_run: Path, env: MjxEnv) -> None:
    saved = from_bytes(None, (pixel_run / "params.msgpack").read_bytes())
    network = _settings(CONFIG).network
    net = make_network(env, network)
    stats = RunningStatistics(**{name: np.asarray(value) for name, value in saved["normalizer"].items()})
    state = env.reset(jax.random.PRNGKey(0))
    image = np.asarray(state.images["overview"])
    assert image.dtype == np.uint8 and image.std() > 0  # a rendered scene, not a blank frame

    goal = np.asarray(state.commands["goal"])

    def act(observation: np.ndarray, picture: np.ndarray, goal: np.ndarray = goal) -> np.ndarray:
        views = {"images": {"overview": picture}, "commands": {"goal": goal}}
        return np.asarray(policy_actions(net, saved["params"], stats, observation, network, views))

    observation = np.asarray(state.observation)
    base = act(observation, image)
    assert np.abs(act(observation, 255 - image) - base).max() > 1e-4  # another image: another action
    assert np.abs(act(observation, image, goal + 0.1) - base).max() > 1e-4  # another goal: another action
    unseen = observation.copy()
    unseen[:, JOINTS:] += 1.0  # everything but joint_pos, the first term
    np.testing.assert_array_equal(act(unseen, image), base)  # the policy does not read the privileged state
    moved = observation.copy()
    moved[:, :JOINTS] += 1.0
    assert np.abs(act(moved, image) - base).max() > 1e-4  # but it reads the joints


def test_eval_runs_the_pixel_policy_from_its_checkpoint(pixel_run: Path, tmp_path: Path) -> None:
    context = RunContext(PluginHost.discover(), tmp_path)
    results = PpoTrainer().evaluate(pixel_run, episodes=2, seed=0, video_path=None, context=context)
    assert results.lengths == [20, 20], results  # neither 20-step episode ends early by an error
    with pytest.raises(ConfigError, match="sees camera images"):  # an MLP of the flat observation cannot hold it
        mlp_policy(pixel_run, _settings(CONFIG).network)


def test_whole_unrolls_carry_their_images_when_advantages_are_recomputed(env: MjxEnv) -> None:
    """Minibatches of whole unrolls (batch-major images) reach the loss: one iteration moves the encoder."""
    network = _settings({"hidden_sizes": [8], "ppo": {"pixels": PIXELS}}).network
    optimization = OptimizationSettings(num_epochs=1, minibatch_size=4)
    returns = ReturnSettings(recompute_advantages=True)
    iteration = make_iteration(
        env, rollout=RolloutSettings(num_steps=2), optimization=optimization, returns=returns, network=network
    )
    state = init_state(env, seed=0, network=network, optimization=optimization)
    before = np.asarray(state.params["encoder_overview"]["Conv_0"]["kernel"])
    state, metrics = iteration(state)
    assert bool(metrics["params_finite"])
    assert np.abs(np.asarray(state.params["encoder_overview"]["Conv_0"]["kernel"]) - before).max() > 0


def test_the_pixels_preset_validates_against_its_task() -> None:
    """The preset's policy sees one 64x64 rgb camera, the joint readings and the goal; its value network the flat
    state; its environments (2 here) render on MuJoCo Warp, and the network it describes builds against them."""
    plugins = PluginHost.discover()
    training = finalize(load_preset("so_arm100_pick_place_pixels", plugins.options())).training
    settings = ppo_settings(options_of(training, options_pb2.ppo), training)
    pixels = settings.network.pixels
    assert pixels is not None and pixels.cameras == ("overview",) and pixels.commands == ("goal",)
    assert settings.network.separate_value_network
    env = RunContext(plugins, Path(training.checkpoint_dir)).create_envs(training, EnvKind.JAX, num_envs=2)
    assert [(camera.name, camera.shape, camera.kind) for camera in env.task.cameras] == [
        ("overview", (64, 64, 3), "rgb")
    ]
    params = init_params(env, settings.network, jax.random.PRNGKey(0))
    # the policy's flat input: 6 joint positions, 6 velocities, 6 servo errors and 6 last actions, and the goal
    assert np.shape(params["policy"]["Dense_0"]["kernel"]) == (pixels.feature_size + 24 + GOAL, 256)
    assert np.shape(params["encoder_overview"]["Conv_0"]["kernel"]) == (8, 8, 3, 32)  # the Nature-CNN default
    assert image_bytes_per_env(env, settings.network) == 64 * 64 * 3


def test_pixel_options_without_a_camera_or_with_unknown_names_are_one_line_config_errors(env: MjxEnv) -> None:
    with pytest.raises(ConfigError, match="pixels.cameras must name at least one") as error:
        _settings({"ppo": {"pixels": {"observation_terms": ["joint_pos"]}}})
    errors = [error.value]
    with pytest.raises(ConfigError, match="one entry per conv layer") as error:
        _settings({"ppo": {"pixels": {"cameras": ["overview"], "channels": [4, 8], "kernel_sizes": [3]}}})
    errors.append(error.value)
    for pixels, message in (
        ({"cameras": ["nowhere"]}, "camera 'nowhere' is not one of the task's cameras \\(overview\\)"),
        ({"cameras": ["overview"], "observation_terms": ["joint_angles"]}, "observation term 'joint_angles'"),
        ({"cameras": ["overview"], "commands": ["target"]}, "command 'target' is not one of the task's commands"),
    ):
        with pytest.raises(ConfigError, match=message) as error:
            make_network(env, _settings({"ppo": {"pixels": pixels}}).network)
        errors.append(error.value)
    assert all("\n" not in str(value) for value in errors), errors


def test_an_offpolicy_pixel_actor_trains_from_its_camera_and_evaluates(tmp_path: Path) -> None:
    """TD3 with a pixel actor (the critics see the flat state): one iteration of 4 steps stores the camera's frames
    in the replay buffer and updates from shifted copies of them; the checkpoint evaluates, and the actor holds
    the camera's encoder."""
    from joshua_core.resources import resolve_data_path
    from joshua_ppo.offpolicy_trainer import Td3Trainer

    config = copy.deepcopy(CONFIG)
    del config["ppo"], config["hidden_sizes"], config["checkpoint_interval"]
    config |= {"trainer": "td3", "minibatch_size": 8, "total_timesteps": NUM_ENVS * NUM_STEPS}
    config["offpolicy"] = {
        "actor_hidden_sizes": [16],
        "critic_hidden_sizes": [16],
        "replay_steps": 8,
        "n_step": 1,
        "learning_starts": 2,
        "video_interval": -1,
        "pixels": PIXELS,
        "image_shift": 2,
    }
    training = TrainingConfig()
    plugins = PluginHost.discover()
    model = str(resolve_data_path("so_arm100/pick_place_mjx.xml"))
    parse_dict({**config, "model_path": model}, training, plugins.options())
    training.checkpoint_dir = str(tmp_path)
    context = RunContext(plugins, tmp_path)
    checkpoint = Td3Trainer().train(training, context)
    history = json.loads((checkpoint / "metrics.json").read_text())["history"]
    assert len(history) == 1 and np.isfinite(history[0]["value_loss"]) and history[0]["value_loss"] > 0
    saved = from_bytes(None, (checkpoint / "params.msgpack").read_bytes())
    assert "encoder_overview" in saved["params"]  # the CNN of the camera the actor sees
    results = Td3Trainer().evaluate(checkpoint, episodes=2, seed=0, video_path=None, context=context)
    assert len(results.returns) == 2
    with pytest.raises(ConfigError, match="only policies of the flat observation export as an MLP"):
        Td3Trainer().export_policy(checkpoint, context=context)
