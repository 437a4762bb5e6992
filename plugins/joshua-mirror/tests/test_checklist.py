"""`joshua checklist RUN` on a real run: a tiny SB3 run of the shipped reach preset with randomization events,
exported by joshua-export; the checklist must say what that run trained with, at what rate, how its joints read
in LeRobot's units, and the commands that deploy it. Bad input is one line, exit 2; a damaged export exits 1."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from joshua_core.cli import main

JOSHUA = [sys.executable, "-m", "joshua_core.cli"]
RUN_CONFIG = """
extends: "so_arm100_reach_sb3"
training {
  num_envs: 2 num_steps: 8 minibatch_size: 16 num_epochs: 1 total_timesteps: 16
  checkpoint_dir: "runs"
  run_name: "reach" hidden_sizes: [8]
  task_config {
    events { name: "servo_kp" term: "randomize_actuator_gains" mode: RESET
             params { key: "kp_range" value: "[0.85, 1.15]" } }
    events { name: "delay" term: "action_delay" mode: RESET params { key: "range" value: "[0, 2]" } }
    events { name: "encoder_noise" term: "observation_noise" mode: INTERVAL interval_steps: 1
             params { key: "std" value: "0.002" } }
  }
}
"""
CALIBRATION_RANGE = (1024, 3072)  # ticks: 180 degrees of every motor


def joshua(*args: str, cwd: Path) -> None:
    env = {**os.environ, "JOSHUA_CHECKPOINT_KEY_FILE": str(cwd / "checkpoint.key")}
    done = subprocess.run([*JOSHUA, *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The run folder of a 16-step SB3 run with three events, its checkpoint exported."""
    work = tmp_path_factory.mktemp("checklist")
    (work / "run.pbtxt").write_text(RUN_CONFIG)
    joshua("--config", "run.pbtxt", cwd=work)
    joshua("export", "runs/reach", cwd=work)
    return work / "runs" / "reach"


def checklist(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    status = main(["checklist", *args])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_the_checklist_says_what_the_run_trained_with_and_how_to_deploy_it(
    run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, err = checklist(capsys, str(run))
    assert status == 0, out + err
    text = " ".join(out.split())  # the items are wrapped
    assert "trained by sb3 on task so_arm100_reach for 16 env steps" in text
    assert "the ONNX file matches its sha256" in text  # the export was checked as deploy checks it
    assert "servo_kp: randomize_actuator_gains (kp_range=(0.85, 1.15)), at each episode's start" in text
    assert "delay: action_delay (range=(0, 2))" in text
    assert "encoder_noise: observation_noise (std=0.002), every 1 step(s)" in text
    assert "runs every 20 ms (50 Hz: timestep 0.002 s x frame_skip 10)" in text
    assert "up to 2 step(s) of action delay: it tolerates about 40 ms" in text
    # friction and masses are gaps of this run; servo gains are not
    gaps = next(line for line in text.split("[you]") if "not randomized" in line)
    assert "friction" in gaps and "masses and inertias" in gaps and "servo gains" not in gaps
    assert "shoulder_pan.pos -110.0 .. 110.0 deg" in text
    assert "gripper.pos 0.0 .. 100.0 %" in text
    checkpoint = run.parent / "reach_step_16"
    assert f"joshua deploy {checkpoint} --lerobot so100_follower --port /dev/ttyACM0" in out
    assert "--max-speed 0.5 --duration 10" in out
    assert "joshua --preset sim_mirror --set simulation.mirror.lerobot.robot_type=so100_follower" in out


def test_a_calibration_file_is_read_and_its_spans_compared(
    run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    motors = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper")
    entries = {motor: {"id": index, "drive_mode": 0, "homing_offset": 0, "range_min": CALIBRATION_RANGE[0],
                       "range_max": CALIBRATION_RANGE[1]} for index, motor in enumerate(motors, 1)}  # fmt: skip
    calibration = tmp_path / "my_arm.json"
    calibration.write_text(json.dumps(entries))
    status, out, _ = checklist(capsys, str(run), "--calibration", str(calibration))
    assert status == 0
    text = " ".join(out.split())
    assert "joint_1 180 vs 220 deg" in text  # the file's span against the model's
    assert f"--calibration {calibration} --target X,Y,Z" in out


def test_a_damaged_export_is_a_problem_of_the_checklist(
    run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    policy = tmp_path / "policy"
    policy.mkdir()
    for name in ("policy.json", "policy.onnx"):
        shutil.copy(run.parent / "reach_step_16" / name, policy / name)
    (policy / "policy.onnx").write_bytes(b"not an onnx graph")
    status, out, _ = checklist(capsys, str(run), "--policy", str(policy))
    assert status == 1
    assert "[!!]" in out and "sha256" in out


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        ("missing", "does not exist"),
        ("empty", "is not a run folder"),
        ("config", "not valid JSON"),
        ("metrics", "not valid JSON"),
        ("deep", "metrics.json: cannot read the run's metrics: nested too deeply"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(
    run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], damage: str, message: str
) -> None:
    target = tmp_path / "runs" / "reach"
    if damage != "missing":
        target.parent.mkdir()
        if damage == "empty":
            target.mkdir()
        else:
            shutil.copytree(run, target)
            shutil.copytree(run.parent / "reach_step_16", target.parent / "reach_step_16")
            damaged = target.parent / "reach_step_16" / ("config.json" if damage == "config" else "metrics.json")
            damaged.write_text("[" * 100_000 + "]" * 100_000 if damage == "deep" else "{not json")
    status, out, err = checklist(capsys, str(target))
    assert status == 2 and not out
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("joshua: error: ") and message in lines[0], err
