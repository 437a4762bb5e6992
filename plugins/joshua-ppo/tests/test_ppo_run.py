"""The PPO trainer end to end on the CPU: a reaching policy learns, its run folder and checkpoints are complete,
`joshua eval` rolls it out, training resumes, bad checkpoints or diverging losses fail clearly, and the live
viewer shows the training environments on a real X server."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest
from flax.serialization import from_bytes
from numpy.typing import NDArray

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError, CorruptCheckpointError, UsageError
from joshua_core.plugins import PluginHost
from joshua_core.run_context import RunContext
from joshua_core.runs import list_runs, run_checkpoints
from joshua_ppo import train_mjx
from joshua_ppo.train import TrainingDiverged
from joshua_ppo.trainer import PpoTrainer

pytestmark = pytest.mark.slow  # every test here trains

JOSHUA = [sys.executable, "-m", "joshua_core.cli"]
# The Ant runs (resume, divergence, the Brax-style network) step MuJoCo Warp: it compiles in seconds on the CPU
# where MJX-JAX takes tens (the resume test: 32 s in the suite against 66 s). The other runs stay on MJX-JAX, cheaper
# for them in the suite: other tests compile the same programs into the run's cache, and long rollouts step faster
# there.
WARP = {"impl": "WARP"}
REACH = {  # 16 envs x 25 steps per iteration, 15 iterations: about 60 s on 2 cores after a 35 s compile
    "num_envs": 16,
    "num_steps": 25,
    "num_epochs": 5,
    "minibatch_size": 100,
    "learning_rate": 1e-3,
    "gamma": 0.97,
    "total_timesteps": 6000,
    "seed": 1,
    "hidden_sizes": [64, 64],
    "run_name": "reach",
    "checkpoint_interval": 4000,
    "ppo": {"video_interval": -1},
}


@pytest.fixture(scope="module")
def reach_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("ppo")
    checkpoint = train_mjx(model_path="so_arm100/scene_mjx.xml", config=REACH, checkpoint_dir=root)
    assert checkpoint == root / "reach_step_6000"
    return root


def test_reach_policy_learns_and_the_run_folder_is_complete(reach_run: Path) -> None:
    run = reach_run / "reach"
    history = json.loads((run / "metrics.json").read_text())["history"]
    # desynchronised first episodes (100 steps, 25 per iteration): episodes end in every iteration, not every 4th
    assert all(record.get("episodes", 0) > 0 for record in history), [r.get("episodes") for r in history]
    # the first episodes (shorter, so smaller sums) have all ended after 4 iterations: compare whole ones
    whole = history[4:]
    returns = [record["mean_return"] for record in whole]
    distances = [record["metrics/distance"] for record in whole]
    # measured: -28.1 -> -12.4 (distance 0.27 -> 0.13) after 15 iterations, -0.5 after 20; every iteration from the
    # 11th on passes both checks
    assert returns[-1] > returns[0] + 5.0, returns
    assert distances[-1] < 0.75 * distances[0], distances
    assert [path.name for path in run_checkpoints(reach_run, "reach")] == [
        "reach_step_0",
        "reach_step_4000",
        "reach_step_6000",
    ]
    saved = from_bytes(None, (reach_run / "reach_step_6000" / "params.msgpack").read_bytes())  # as a user loads it
    assert set(saved) == {"params", "normalizer"} and saved["params"]["log_std"].shape == (6,)
    config = json.loads((reach_run / "reach_step_6000" / "config.json").read_text())
    assert config["trainer"] == "ppo" and config["task"] == "so_arm100_reach" and config["seed"] == 1
    assert config["settings"]["optimization"]["minibatch_size"] == 100
    curves = cv2.imread(str(run / "training_curves.png"))
    assert curves is not None and curves.shape[0] > 400 and len(np.unique(curves.reshape(-1, 3), axis=0)) > 20
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = EventAccumulator(str(run / "tensorboard"))
    events.Reload()
    assert "mean_return" in events.Tags()["scalars"] and len(events.Scalars("loss")) == 15


def test_joshua_eval_reports_intervals_and_films_a_grid_of_episodes(reach_run: Path) -> None:
    video, results = reach_run / "eval.mp4", reach_run / "eval.json"
    done = subprocess.run(
        [*JOSHUA, "eval", str(reach_run / "reach"), "--episodes", "4", "--grid", "2", "--video", str(video),
         "--json", str(results)],
        capture_output=True,
        text=True,
        timeout=600,  # four episodes rolled out, two rendered side by side on a CPU: about 60 s on a loaded machine
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "mean_return:" in done.stdout and "final_distance:" in done.stdout
    assert "95 % interval [" in done.stdout and "(Student t, 3 degrees of freedom)" in done.stdout
    document = json.loads(results.read_text())
    returns = document["per_episode"]["return"]
    assert len(returns) == 4 and document["mean_return"] == pytest.approx(np.mean(returns))
    low, high = document["mean_return_ci95"]
    assert low < document["mean_return"] < high and "success_rate" not in document  # reach has no success metric
    capture = cv2.VideoCapture(str(video))
    assert int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) == 100  # 100-step episodes, side by side
    ok, frame = capture.read()
    assert ok and frame.shape == (480, 2 * 640, 3)  # the grid's layout: joshua-render's test_grid
    tiles = [frame[:, c * 640 : (c + 1) * 640] for c in range(2)]
    assert all(tile.std() > 10 for tile in tiles)
    assert all((tile[4:26, 8:300].min(axis=-1) > 200).sum() > 50 for tile in tiles)  # each tile's white label


def test_a_corrupt_checkpoint_is_a_clear_error(reach_run: Path, tmp_path: Path) -> None:
    broken = tmp_path / "reach_step_4000"
    subprocess.run(["cp", "-r", str(reach_run / "reach_step_4000"), str(broken)], check=True)
    params = broken / "params.msgpack"
    params.write_bytes(params.read_bytes()[:100])
    with pytest.raises(CorruptCheckpointError, match="params.msgpack"):
        PpoTrainer().evaluate(
            broken, episodes=2, seed=0, video_path=None, context=RunContext(PluginHost.discover(), tmp_path)
        )
    done = subprocess.run([*JOSHUA, "eval", str(broken), "--no-video"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 2 and "cannot load" in done.stderr and "Traceback" not in done.stderr


ANT = {
    "task": "ant_locomotion",
    "num_envs": 8,
    "num_steps": 5,
    "minibatch_size": 40,
    "num_epochs": 1,
    "total_timesteps": 80,
    "run_name": "ant",
    "checkpoint_interval": 40,
    "hidden_sizes": [32],
    "ppo": {"video_interval": -1},
}


def test_training_resumes_from_the_newest_checkpoint_with_its_optimizer(tmp_path: Path) -> None:
    filmed = {**ANT, "mjx": WARP, "ppo": {**ANT["ppo"], "video_interval": 2, "video_steps": 12}}
    train_mjx(model_path="ant/ant_mjx.xml", config=filmed, checkpoint_dir=tmp_path)
    videos = sorted(path.name for path in (tmp_path / "ant" / "videos").iterdir())
    assert videos == ["step_80.mp4"], videos  # every 2nd iteration
    capture = cv2.VideoCapture(str(tmp_path / "ant" / "videos" / "step_80.mp4"))
    frames = [frame for ok, frame in iter(capture.read, (False, None)) if ok]
    assert len(frames) >= 12 and frames[0].shape == (480, 640, 3) and frames[0].std() > 10, len(frames)
    first = from_bytes(None, (tmp_path / "ant_step_80" / "train_state.msgpack").read_bytes())
    resumed = {**ANT, "mjx": WARP, "total_timesteps": 160, "resume": True}
    checkpoint = train_mjx(model_path="ant/ant_mjx.xml", config=resumed, checkpoint_dir=tmp_path)
    assert checkpoint.name == "ant_step_160"
    second = from_bytes(None, (checkpoint / "train_state.msgpack").read_bytes())
    assert second["iteration"] == 4 and first["iteration"] == 2
    adam_counts = [int(np.asarray(leaf)) for leaf in _leaves(second["opt_state"]) if np.ndim(leaf) == 0]
    assert 4 in adam_counts  # 2 iterations x 1 epoch x 1 minibatch, twice: the optimizer went on counting
    history = json.loads((checkpoint / "metrics.json").read_text())["history"]
    assert [record["step"] for record in history] == [40, 80, 120, 160]


def test_diverging_training_stops_with_a_clear_message_and_keeps_the_last_good_checkpoint(tmp_path: Path) -> None:
    config = {**ANT, "mjx": WARP, "learning_rate": 1e30, "run_name": "nan", "ppo": {**ANT["ppo"], "max_grad_norm": -1}}
    with pytest.raises(TrainingDiverged, match="diverged in iteration"):
        train_mjx(model_path="ant/ant_mjx.xml", config=config, checkpoint_dir=tmp_path)
    kept = run_checkpoints(tmp_path, "nan")
    assert kept and all(
        np.isfinite(np.asarray(leaf)).all()
        for leaf in _leaves(from_bytes(None, (kept[-1] / "params.msgpack").read_bytes()))
    )


def test_brax_style_network_round_trips_through_eval(tmp_path: Path) -> None:
    """Separate policy and value networks, swish, a state-dependent std and tanh-squashed actions, trained with
    Brax's advantage estimator and an annealed learning rate."""
    options = {
        **ANT["ppo"],
        "value_hidden_sizes": [16],
        "squash_actions": True,
        "activation": "swish",
        "state_dependent_std": True,
        "advantage": "LAMBDA_RETURN",
        "anneal_learning_rate": True,
    }
    # the network is the subject: any physics, and episodes short enough for `joshua eval` to roll out at once
    config = {**ANT, "mjx": WARP, "task_config": {"episode_length": 20}, "run_name": "brax", "hidden_sizes": [8, 8]}
    config["ppo"] = options
    checkpoint = train_mjx(model_path="ant/ant_mjx.xml", config=config, checkpoint_dir=tmp_path)
    params = from_bytes(None, (checkpoint / "params.msgpack").read_bytes())["params"]
    kernels = sorted(tuple(np.shape(layer["kernel"])) for name, layer in params.items() if name.startswith("Dense"))
    observation_size = 105
    # the policy head outputs the mean and the std of each of the 8 actions
    assert kernels == sorted([(observation_size, 8), (8, 8), (8, 16), (observation_size, 16), (16, 1)]), kernels
    assert "log_std" not in params
    history = json.loads((tmp_path / "brax" / "metrics.json").read_text())["history"]
    assert all(0.001 <= record["action_std"] < 10.0 for record in history), history
    # one gradient step per iteration of 40 of the 80 steps: the rate falls linearly from 3e-4 to 0
    assert [record["learning_rate"] for record in history] == pytest.approx([3e-4, 1.5e-4]), history
    done = subprocess.run(
        [*JOSHUA, "eval", str(checkpoint), "--no-video", "--episodes", "2"], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr[-2000:]


def test_bad_settings_are_config_errors(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="minibatch_size 30 must divide"):
        train_mjx(model_path="ant/ant_mjx.xml", config={**ANT, "minibatch_size": 30}, checkpoint_dir=tmp_path)
    with pytest.raises(ConfigError, match="value_hidden_sizes must be positive"):
        train_mjx(
            model_path="ant/ant_mjx.xml", config={**ANT, "ppo": {"value_hidden_sizes": [0]}}, checkpoint_dir=tmp_path
        )
    with pytest.raises(ConfigError, match="activation 'gelu' is not one of: relu, swish"):
        train_mjx(model_path="ant/ant_mjx.xml", config={**ANT, "ppo": {"activation": "gelu"}}, checkpoint_dir=tmp_path)
    for name in ("desired_kl", "max_kl"):
        with pytest.raises(ConfigError, match=f"{name} must not be negative"):
            train_mjx(model_path="ant/ant_mjx.xml", config={**ANT, "ppo": {name: -0.01}}, checkpoint_dir=tmp_path)
    with pytest.raises(ConfigError, match="desired_kl and an annealed learning rate cannot be combined"):
        train_mjx(
            model_path="ant/ant_mjx.xml",
            config={**ANT, "ppo": {"desired_kl": 0.01, "anneal_learning_rate": True}},
            checkpoint_dir=tmp_path,
        )
    with pytest.raises(ConfigError, match="no_such_field"):
        train_mjx(model_path="ant/ant_mjx.xml", config={"no_such_field": 1}, checkpoint_dir=tmp_path)
    for name, problem in (("/../x", "holds a '/'"), ("..", "not a name of its own"), ("x_step_9", "_step_<N>")):
        with pytest.raises(UsageError, match=f"training.run_name '{re.escape(name)}' .*{re.escape(problem)}"):
            train_mjx(model_path="ant/ant_mjx.xml", config={**ANT, "run_name": name}, checkpoint_dir=tmp_path)
    assert not any(tmp_path.iterdir())  # no run folder left behind by a rejected config
    training = TrainingConfig(task="ant_locomotion", backend="mujoco")
    with pytest.raises(ConfigError, match="backend 'mujoco' does not provide; backends that do: mjx"):
        PpoTrainer().train(training, RunContext(PluginHost.discover(), tmp_path))


def _leaves(tree: object) -> list[object]:
    if isinstance(tree, dict):
        return [leaf for value in tree.values() for leaf in _leaves(value)]
    return [tree]


def test_live_viewer_shows_the_training_ants_and_closing_it_lets_training_finish(
    xvfb: str, screenshot: Callable[[str], NDArray[np.uint8]], tmp_path: Path
) -> None:
    settings = {
        "num_envs": 4, "num_steps": 5, "minibatch_size": 20, "num_epochs": 1, "total_timesteps": 4 * 5 * 300,
        "checkpoint_dir": str(tmp_path), "run_name": "live", "ppo.viewer": "ON", "ppo.video_interval": -1,
        "hidden_sizes": "[16]",
    }  # fmt: skip
    overrides = [arg for name, value in settings.items() for arg in ("--set", f"training.{name}={value}")]
    environment = {key: value for key, value in os.environ.items() if key not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    environment["DISPLAY"] = xvfb
    process = subprocess.Popen(
        [*JOSHUA, "--preset", "ant_train_mjx", *overrides],
        env=environment,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 180
        while ant_pixels(screenshot(xvfb)) < 300:  # the Ant's body material is tan: rgb (0.8, 0.6, 0.4)
            assert process.poll() is None, f"training ended before the viewer showed the ants: {process.communicate()}"
            assert time.monotonic() < deadline, "the live viewer did not show the ants within 3 minutes"
            time.sleep(0.5)
        window = subprocess.run(
            ["xdotool", "search", "--name", "^MuJoCo"], env=environment, capture_output=True, text=True
        )
        assert window.stdout.split(), "no MuJoCo window"
        subprocess.run(
            ["xdotool", "windowfocus", "--sync", window.stdout.split()[0], "key", "ctrl+q"], env=environment, check=True
        )
        stdout, stderr = process.communicate(timeout=300)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, stderr[-3000:]
    assert "ppo: 6000 steps" in stdout and (tmp_path / "live_step_6000" / "params.msgpack").is_file()
    assert "Traceback" not in stderr


def ant_pixels(rgb: NDArray[np.uint8]) -> int:
    r, g, b = (rgb[..., i].astype(int) for i in range(3))
    return int(np.count_nonzero((r > 90) & (r - b > 50) & (g - b > 20) & (r - g > 15)))


def test_runs_started_together_get_their_own_folders_and_a_name_in_use_is_refused(tmp_path: Path) -> None:
    """Two runs with the default name started at once train in two folders; a third asking for one of those
    names while it trains fails at once, in one line naming the process that holds it, touching nothing."""
    settings = {
        "num_envs": 4, "num_steps": 5, "minibatch_size": 20, "num_epochs": 1, "total_timesteps": 10**9,
        "checkpoint_dir": str(tmp_path), "ppo.viewer": "OFF", "ppo.video_interval": -1, "hidden_sizes": "[16]",
    }  # fmt: skip
    overrides = [arg for name, value in settings.items() for arg in ("--set", f"training.{name}={value}")]
    command = [*JOSHUA, "--preset", "ant_train_mjx", *overrides]
    environment = {**os.environ, "PYTHONUNBUFFERED": "1"}
    first = [
        subprocess.Popen(command, env=environment, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        for _ in range(2)
    ]
    try:
        for process in first:  # printed once the run folder and its config.json are written
            assert process.stdout is not None
            lines = iter(process.stdout.readline, "")
            assert any("compiling the training iteration" in line for line in lines), process.poll()
        folders = list_runs(tmp_path)
        assert len(folders) == 2 and all(folder.name.startswith("ant_locomotion_") for folder in folders), folders
        holders = {int((folder / ".lock").read_text()): folder for folder in folders}
        assert set(holders) == {process.pid for process in first}
        taken = folders[0]
        config = (taken / "config.json").read_bytes()
        third = subprocess.run(
            [*command, "--set", f"training.run_name={taken.name}"], capture_output=True, text=True, timeout=300
        )
        errors = [line for line in third.stderr.splitlines() if line.startswith("joshua: error:")]
        assert third.returncode == 2 and "Traceback" not in third.stderr, third.stderr[-2000:]
        holder = next(pid for pid, folder in holders.items() if folder == taken)
        assert len(errors) == 1 and f"run '{taken.name}'" in errors[0] and f"process {holder}" in errors[0], errors
        assert (taken / "config.json").read_bytes() == config and (taken / ".lock").read_text().strip() == str(holder)
        assert all(process.poll() is None for process in first)  # both still training
    finally:
        for process in first:
            process.kill()
            process.communicate()
