"""The sb3 trainer end to end through the `joshua` command: it learns so_arm100_reach, `joshua eval`
reports and records it, a SIGKILLed run resumes from its last checkpoint, and checkpoints that this
user did not write are refused."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest
import torch

from joshua_core.outputs import MARKER
from joshua_core.runs import checkpoint_step, list_runs, run_checkpoints
from joshua_sb3.run_folder import KEY_ENV_VAR, MANIFEST_FILE, MODEL_FILE

pytestmark = pytest.mark.slow  # every test here trains

JOSHUA = Path(sys.executable).parent / "joshua"
PRESET = "so_arm100_reach_sb3"
RESULT_LINE = re.compile(r"^(?P<name>[a-z_]+): (?P<value>[-+.\deE]+|nan|inf)$")
LEARNING_STEPS = 24_000  # ~12 s on 2 idle cores; the preset's 300k steps reach about 5 mm


def joshua(*args: str, cwd: Path, key: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    """Run `joshua ARGS` with its own checkpoint key (not the user's)."""
    return subprocess.run(
        [str(JOSHUA), *args],
        cwd=cwd,
        env={**os.environ, KEY_ENV_VAR: str(key)},
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def checkpoint_folders(run_dir: Path) -> list[Path]:
    """The run's checkpoints, `<checkpoint_dir>/<run>_step_<N>/`, oldest first."""
    return run_checkpoints(run_dir.parent, run_dir.name)


def evaluation(process: subprocess.CompletedProcess[str]) -> dict[str, float]:
    """The `name: value` lines `joshua eval` prints."""
    assert process.returncode == 0, process.stderr
    pairs = (RESULT_LINE.match(line) for line in process.stdout.splitlines())
    return {match["name"]: float(match["value"]) for match in pairs if match}


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A short PPO run of the shipped preset: (run folder, checkpoint key)."""
    work = tmp_path_factory.mktemp("sb3")
    key = work / "checkpoint.key"
    started = time.perf_counter()
    process = joshua(
        "--preset", PRESET,
        "--set", f"training.total_timesteps={LEARNING_STEPS}",
        "--set", "training.checkpoint_dir=runs",
        "--set", "training.run_name=reach",
        cwd=work, key=key,
    )  # fmt: skip
    assert process.returncode == 0, process.stderr
    print(f"trained {LEARNING_STEPS} steps in {time.perf_counter() - started:.1f} s")
    return work / "runs" / "reach", key


def test_learns_to_reach(trained: tuple[Path, Path]) -> None:
    run_dir, key = trained
    untrained = evaluation(joshua("eval", str(checkpoint_folders(run_dir)[0]), "--no-video", cwd=run_dir, key=key))
    learned = evaluation(joshua("eval", str(run_dir), "--no-video", cwd=run_dir, key=key))
    print(f"final distance: untrained {untrained['final_distance']:.4f} m, trained {learned['final_distance']:.4f} m")
    assert learned["final_distance"] <= 0.5 * untrained["final_distance"]
    assert learned["mean_return"] > untrained["mean_return"]


def test_run_folder_layout(trained: tuple[Path, Path]) -> None:
    run_dir, _ = trained
    config = json.loads((run_dir / "config.json").read_text())
    assert config["trainer"] == "sb3" and config["algorithm"] == "PPO" and config["task"] == "so_arm100_reach"
    assert config["training"]["num_envs"] == 32 and config["settings"]["hidden_sizes"] == [64, 64]
    metrics = json.loads((run_dir / "metrics.json").read_text())
    assert metrics["num_timesteps"] == LEARNING_STEPS and metrics["steps_per_second"] > 0
    logged = metrics["history"][-1]
    for name in ("rollout/ep_rew_mean", "reward/distance", "reward/near", "reward/action_rate", "metrics/distance"):
        assert name in logged, sorted(logged)
    assert list((run_dir / "tensorboard").glob("events.out.tfevents.*"))
    curves = matplotlib.image.imread(run_dir / "training_curves.png")  # return and distance panels
    assert curves.shape[0] > 400 and len(np.unique(curves.reshape(-1, curves.shape[-1]), axis=0)) > 10
    steps = [checkpoint_step(folder) for folder in checkpoint_folders(run_dir)]
    assert steps[0] == 0 and steps[-1] == LEARNING_STEPS and steps == sorted(set(steps)) and len(steps) >= 5
    newest = checkpoint_folders(run_dir)[-1]
    assert {path.name for path in newest.iterdir()} == {
        "config.json", "metrics.json", "manifest.json", "model.zip", "vecnormalize.pkl", MARKER
    }  # fmt: skip
    assert not list(run_dir.parent.glob(".*")), "a temporary checkpoint folder was left behind"
    names = {path.name for path in run_dir.iterdir()}
    assert names >= {".lock", "config.json", "metrics.json", "training_curves.png", "tensorboard"}, names
    assert "checkpoints" not in names  # they lie beside the run folder: <checkpoint_dir>/<run>_step_<N>/


def test_eval_prints_the_return_and_films_a_grid(trained: tuple[Path, Path], tmp_path: Path) -> None:
    run_dir, key = trained
    video = tmp_path / "reach.mp4"
    process = joshua(
        "eval", str(run_dir), "--episodes", "2", "--grid", "2", "--video", str(video), cwd=tmp_path, key=key
    )
    results = evaluation(process)
    assert set(results) >= {"mean_return", "mean_length", "final_distance"} and results["mean_length"] == 100
    assert "(Student t, 1 degrees of freedom)" in process.stdout
    document = json.loads((run_dir / "eval.json").read_text())  # written next to the run
    assert document["trainer"] == "sb3" and document["per_episode"]["length"] == [100, 100]
    import cv2

    capture = cv2.VideoCapture(str(video))
    frames = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
    ok, frame = capture.read()
    assert ok and frame.shape == (480, 2 * 640, 3) and frames == 101, frames  # the reset state, 100 steps
    for tile in (frame[:, :640], frame[:, 640:]):
        assert tile.std() > 5 and (tile[4:26, 8:300].min(axis=-1) > 200).sum() > 50  # scene and white label
    assert f"video: {video}" in process.stdout


def test_checkpoints_this_user_did_not_write_are_refused(trained: tuple[Path, Path], tmp_path: Path) -> None:
    run_dir, key = trained
    copy = tmp_path / "copy"  # the run folder and its checkpoints beside it, as another machine would get them
    shutil.copytree(run_dir, copy)
    for folder in checkpoint_folders(run_dir):
        shutil.copytree(folder, tmp_path / f"copy_step_{checkpoint_step(folder)}")
    checkpoint = checkpoint_folders(copy)[-1]

    other_key = joshua("eval", str(copy), "--no-video", cwd=tmp_path, key=tmp_path / "someone_else.key")
    assert other_key.returncode == 2 and "Traceback" not in other_key.stderr
    assert "refusing to load checkpoint" in other_key.stderr and "--trust-checkpoint" in other_key.stderr

    with zipfile.ZipFile(checkpoint / MODEL_FILE, "a") as archive:  # a changed model.zip, with our key
        archive.writestr("extra", b"payload")
    changed = joshua("eval", str(copy), "--no-video", cwd=tmp_path, key=key)
    assert changed.returncode == 2 and "model.zip changed after it was written" in changed.stderr

    (checkpoint / MANIFEST_FILE).unlink()  # not written by joshua-sb3 at all
    foreign = joshua("eval", str(checkpoint), "--no-video", cwd=tmp_path, key=key)
    assert foreign.returncode == 2 and "has no manifest.json" in foreign.stderr

    trust = ("--no-video", "--episodes", "2", "--trust-checkpoint")
    trusted = joshua("eval", str(checkpoint), *trust, cwd=tmp_path, key=key)
    assert "mean_return" in evaluation(trusted)  # the extra zip member does not hurt SB3

    (checkpoint / MODEL_FILE).write_bytes(b"not a zip file")
    corrupt = joshua("eval", str(checkpoint), *trust, cwd=tmp_path, key=key)
    assert corrupt.returncode == 2 and "cannot load checkpoint" in corrupt.stderr and "Traceback" not in corrupt.stderr


def test_an_edited_config_of_a_signed_checkpoint_is_refused(trained: tuple[Path, Path], tmp_path: Path) -> None:
    run_dir, key = trained
    checkpoint = tmp_path / "edited_step_0"  # the untrained checkpoint: its model.zip is as signed
    shutil.copytree(checkpoint_folders(run_dir)[0], checkpoint)
    config = json.loads((checkpoint / "config.json").read_text())
    config["training"]["seed"] = 1234
    (checkpoint / "config.json").write_text(json.dumps(config))
    edited = joshua("eval", str(checkpoint), "--no-video", "--episodes", "2", cwd=tmp_path, key=key)
    assert edited.returncode == 2 and "Traceback" not in edited.stderr, edited.stderr[-2000:]
    assert "config.json changed after it was written" in edited.stderr.strip().splitlines()[-1]


def adam_steps(checkpoint: Path) -> int:
    """How many updates the Adam optimizer saved in a checkpoint has made."""
    with zipfile.ZipFile(checkpoint / MODEL_FILE) as archive, archive.open("policy.optimizer.pth") as handle:
        state = torch.load(handle, weights_only=True)["state"]
    return int(next(iter(state.values()))["step"])


def test_killed_run_resumes_from_its_last_checkpoint(tmp_path: Path) -> None:
    key = tmp_path / "checkpoint.key"
    # 8 envs x 25 steps = 200 per rollout, 2 epochs of 2 minibatches: 4 optimizer updates per rollout.
    settings = [
        "--preset", PRESET,
        "--set", "training.num_envs=8", "--set", "training.num_steps=25", "--set", "training.num_epochs=2",
        "--set", "training.minibatch_size=100", "--set", "training.checkpoint_interval=400",
        "--set", "training.checkpoint_dir=runs", "--set", "training.run_name=killed",
    ]  # fmt: skip
    run_dir = tmp_path / "runs" / "killed"
    process = subprocess.Popen(
        [str(JOSHUA), *settings, "--set", "training.total_timesteps=1000000"],
        cwd=tmp_path,
        env={**os.environ, KEY_ENV_VAR: str(key)},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 120
    while len(checkpoint_folders(run_dir)) < 3 and time.monotonic() < deadline:  # step 0, then every 400 steps
        time.sleep(0.2)
    process.send_signal(signal.SIGKILL)
    process.wait()
    folders = checkpoint_folders(run_dir)
    assert len(folders) >= 3, "no checkpoints within 120 s"
    last = folders[-1]
    killed_at = checkpoint_step(last)
    assert killed_at >= 800 and adam_steps(last) == killed_at // 200 * 4

    total = killed_at + 1000
    again = joshua(*settings, "--set", f"training.total_timesteps={total}", cwd=tmp_path, key=key)
    assert again.returncode == 2 and "exists; continue it with --set training.resume=true" in again.stderr
    resumed = joshua(
        *settings, "--set", f"training.total_timesteps={total}", "--set", "training.resume=true",
        cwd=tmp_path, key=key,
    )  # fmt: skip
    assert resumed.returncode == 0, resumed.stderr
    assert f"resuming {run_dir.relative_to(tmp_path)} from {last.name} ({killed_at} steps)" in resumed.stdout
    final = checkpoint_folders(run_dir)[-1]
    assert final.name == f"killed_step_{total}"
    assert adam_steps(final) == total // 200 * 4  # the optimizer continued: its step count did not restart
    history = json.loads((run_dir / "metrics.json").read_text())["history"]
    steps = [record["step"] for record in history]
    assert steps == sorted(steps) and steps[0] <= killed_at < steps[-1]


def test_sac_keeps_its_replay_buffer_in_the_newest_checkpoint_and_resumes(tmp_path: Path) -> None:
    key = tmp_path / "checkpoint.key"
    settings = [
        "--preset", PRESET, "--set", "training.sb3.algorithm=SAC", "--set", "training.num_envs=4",
        "--set", "training.minibatch_size=64", "--set", "training.checkpoint_interval=200",
        "--set", "training.checkpoint_dir=runs", "--set", "training.run_name=sac",
        "--set", "training.gae_lambda=0", "--set", "training.clip_epsilon=0",
    ]  # fmt: skip
    first = joshua(*settings, "--set", "training.total_timesteps=400", cwd=tmp_path, key=key)
    assert first.returncode == 0, first.stderr
    folders = checkpoint_folders(tmp_path / "runs" / "sac")
    assert [folder.name for folder in folders][-1] == "sac_step_400" and len(folders) == 3
    assert [(folder / "replay_buffer.pkl").exists() for folder in folders] == [False, False, True]
    resumed = joshua(
        *settings, "--set", "training.total_timesteps=600", "--set", "training.resume=true", cwd=tmp_path, key=key
    )
    assert resumed.returncode == 0, resumed.stderr
    assert "from sac_step_400 (400 steps)" in resumed.stdout
    assert checkpoint_folders(tmp_path / "runs" / "sac")[-1].name == "sac_step_600"


def test_runs_started_together_get_their_own_folders_and_a_name_in_use_is_refused(tmp_path: Path) -> None:
    """Two runs with the default name started at once train in two folders; a third asking for one of those
    names while it trains fails at once, in one line naming the process that holds it, touching nothing."""
    key = tmp_path / "checkpoint.key"
    settings = [
        "--preset",
        PRESET,
        "--set",
        "training.checkpoint_dir=runs",
        "--set",
        "training.total_timesteps=10000000",
    ]
    environment = {**os.environ, KEY_ENV_VAR: str(key)}
    logs, first = [tmp_path / f"stderr_{index}.txt" for index in range(2)], []
    for log in logs:
        with log.open("w") as stderr:
            first.append(subprocess.Popen([str(JOSHUA), *settings], cwd=tmp_path, env=environment, stderr=stderr))

    def running() -> bool:
        return all(process.poll() is None for process in first)

    def why() -> list[str]:
        return [log.read_text()[-1500:] for log in logs]  # what a run that stopped said

    try:
        deadline = time.monotonic() + 120
        while len(runs := list_runs(tmp_path / "runs")) < 2:  # both made their folder and wrote its config
            assert running() and time.monotonic() < deadline, why()
            time.sleep(0.1)
        assert all(run.name.startswith("so_arm100_reach_ppo_") for run in runs), runs
        holders = {int((run / ".lock").read_text()): run for run in runs}
        assert set(holders) == {process.pid for process in first}
        taken = runs[0]
        config = (taken / "config.json").read_bytes()
        third = joshua(*settings, "--set", f"training.run_name={taken.name}", cwd=tmp_path, key=key)
        errors = [line for line in third.stderr.splitlines() if line.startswith("joshua: error:")]
        assert third.returncode == 2 and "Traceback" not in third.stderr, third.stderr[-2000:]
        holder = next(pid for pid, run in holders.items() if run == taken)
        assert len(errors) == 1 and f"run '{taken.name}'" in errors[0] and f"process {holder}" in errors[0], errors
        assert (taken / "config.json").read_bytes() == config and (taken / ".lock").read_text().strip() == str(holder)
        assert running(), why()  # both still training
    finally:
        for process in first:
            process.kill()
            process.wait()


def test_a_run_name_that_is_not_a_plain_name_is_refused_before_training(tmp_path: Path) -> None:
    for name, problem in (("/../x", "holds a '/'"), ("a/b", "holds a '/'"), ("reach_step_99999", "_step_<N>")):
        done = joshua(
            "--preset", PRESET, "--set", "training.checkpoint_dir=runs", "--set", f"training.run_name={name}",
            cwd=tmp_path, key=tmp_path / "key",
        )  # fmt: skip
        assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr[-2000:]
        assert f"training.run_name '{name}' " in done.stderr and problem in done.stderr, done.stderr
    assert not (tmp_path / "runs").exists() or not any((tmp_path / "runs").iterdir())  # no run folder begun
