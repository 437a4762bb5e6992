"""`joshua sysid` end to end: recordings simulated with known, perturbed SO-ARM100 parameters are written as CSV
files, and the real `joshua` process must find those parameters from the nominal model; bad input is one line,
exit 2."""

from __future__ import annotations

import errno
import json
import math
import os
import struct
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from joshua_core.cli import main
from joshua_core.resources import models_dir
from joshua_core.runs import LOCK_FILE
from joshua_sysid import fit, recordings, report, synthetic

JOSHUA = Path(sys.executable).parent / "joshua"
ARM = models_dir() / "so_arm100" / "so_arm100.xml"
# The "real" arm: stiffer, less damped, heavier rotor, more friction than the nominal model.
FACTORS = {"kp": 1.3, "damping": 0.7, "armature": 1.5}
FRICTION_OFFSET = 0.05
SEEDS = (0, 1)
DURATION_S = 3.0
RATE_HZ = 100.0


def joshua(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(JOSHUA), *args], cwd=cwd, capture_output=True, text=True, timeout=600, env={**os.environ}
    )


def true_spec() -> tuple[mujoco.MjSpec, list[recordings.Servo]]:
    """The nominal arm with every servo's parameters perturbed by FACTORS and FRICTION_OFFSET."""
    spec = mujoco.MjSpec.from_file(str(ARM))
    servos = recordings.model_servos(spec.copy().compile(), ARM)
    for servo in servos:
        for kind, factor in FACTORS.items():
            fit.write_value(spec, servo, kind, fit.read_value(spec, servo, kind) * factor)
        fit.write_value(spec, servo, "frictionloss", fit.read_value(spec, servo, "frictionloss") + FRICTION_OFFSET)
    return spec, servos


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[Path], dict[str, dict[str, float]]]:
    """Recordings of the perturbed arm as CSV files, and its true parameters {joint: {kind: value}}."""
    folder = tmp_path_factory.mktemp("recordings")
    spec, servos = true_spec()
    model = spec.compile()
    paths = []
    for seed in SEEDS:
        times, positions, targets = synthetic.simulate(model, servos, seed, DURATION_S, RATE_HZ)
        paths.append(folder / f"arm_{seed}.csv")
        synthetic.write_csv(paths[-1], servos, times, positions, targets)
    truth = {s.joint: {k: fit.read_value(spec, s, k) for k in fit.KINDS} for s in servos}
    return paths, truth


@pytest.mark.slow
def test_fit_finds_the_true_parameters_and_writes_a_model_that_compiles(recorded, tmp_path: Path) -> None:
    paths, truth = recorded
    done = joshua("sysid", *map(str, paths), "--output-dir", "out", "--run-name", "arm", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    run = tmp_path / "out" / "arm"
    report = json.loads((run / "report.json").read_text())
    for joint, kinds in truth.items():
        for kind, value in kinds.items():
            identified = report["parameters"][joint][kind]["identified"]
            assert identified == pytest.approx(value, rel=0.05), (joint, kind, identified, value)
    tracking = report["tracking_rms"]
    for joint in truth:
        assert tracking["after"][joint] * 5 <= tracking["before"][joint], (joint, tracking)
    assert tracking["overall_before"] > 0.02  # the nominal model was clearly off
    assert "joint_1" in done.stdout and "tracking RMS" in done.stdout and "warning" not in done.stderr
    assert report["fit"]["at_bounds"] == report["fit"]["poorly_tracked"] == []
    # The calibrated model compiles from its own folder (meshes copied beside it) and holds the fitted values.
    model = mujoco.MjModel.from_xml_path(str(run / report["outputs"]["model"]))
    assert model.nmesh == mujoco.MjModel.from_xml_path(str(ARM)).nmesh > 0
    for joint, kinds in truth.items():
        actuator = model.actuator(f"{joint}_position")
        assert actuator.gainprm[0] == pytest.approx(kinds["kp"], rel=0.05)
        assert actuator.biasprm[1] == -actuator.gainprm[0]
        assert model.dof_damping[model.joint(joint).dofadr[0]] == pytest.approx(kinds["damping"], rel=0.05)
        assert model.dof_armature[model.joint(joint).dofadr[0]] == pytest.approx(kinds["armature"], rel=0.05)
    png = (run / report["outputs"]["plot"]).read_bytes()
    assert png.startswith(b"\x89PNG")


def write(folder: Path, name: str, lines: list[str]) -> str:
    path = folder / name
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def rows(count: int, *, columns: int = 6, targets: bool = True, value: str | None = None) -> list[str]:
    """`count` rows 10 ms apart; every joint and target moves from 0.1 rad by 1 mrad a row unless `value` is given."""
    width = columns * (2 if targets else 1)
    return [",".join([f"{i * 0.01:.2f}", *([value or f"{0.1 + i * 1e-3:.4f}"] * width)]) for i in range(count)]


JOINTS = [f"joint_{i}" for i in range(1, 7)]
HEADER = ",".join(["timestamp", *JOINTS, *(f"{j}.target" for j in JOINTS)])


@pytest.mark.parametrize(
    ("case", "expected"),
    [
        ("no_targets", "no commanded targets; joshua sysid needs a '<joint>.target' column"),
        ("malformed", "row has 3 values"),
        ("unknown_joint", "'joint_9' (did you mean"),
        ("non_finite", "NaN or infinite value"),
        ("too_short", "too short to fit: 5 samples"),
        ("missing_joint", "no column for the actuated joints joint_6"),
        ("no_position_actuators", "has no actuators"),
        ("bad_kind", "--fit: unknown parameter 'dampng' (did you mean damping?)"),
        ("run_name_path", "--run-name '/../../../../tmp/x' holds a '/'"),
        ("run_name_dots", "--run-name '..' is not a name of its own"),
        ("run_name_empty", "--run-name '' is empty"),
        ("run_name_step", "--run-name 'x_step_99999' ends in _step_<N>"),
        ("no_motion", "no joint moves (each spans less than 0.0001 rad or m), so it tells the fit nothing"),
        ("implausible", "joint 'joint_1' has a position of 5e+08, far outside its range"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path: Path, case: str, expected: str) -> None:
    good = write(tmp_path, "good.csv", [HEADER, *rows(150)])
    arguments = {
        "no_targets": [write(tmp_path, "plain.csv", [",".join(["timestamp", *JOINTS]), *rows(150, targets=False)])],
        "malformed": [write(tmp_path, "bad.csv", [HEADER, *rows(3), "0.5,0.1,0.2"])],
        "unknown_joint": [write(tmp_path, "j9.csv", ["timestamp,joint_9,joint_9.target", "0,0,0"])],
        "non_finite": [write(tmp_path, "nan.csv", [HEADER, *rows(30), *rows(1, value="nan")[0:1]])],
        "too_short": [write(tmp_path, "short.csv", [HEADER, *rows(5)])],
        "missing_joint": [
            write(
                tmp_path,
                "five.csv",
                [",".join(["timestamp", *JOINTS[:5], *(f"{j}.target" for j in JOINTS[:5])]), *rows(150, columns=5)],
            )
        ],
        "no_position_actuators": [good, "--model", write(tmp_path, "bare.xml", [BARE_MODEL])],
        "bad_kind": [good, "--fit", "kp,dampng"],
        "run_name_path": [good, "--run-name", "/../../../../tmp/x"],  # refused before the fit
        "run_name_dots": [good, "--run-name", ".."],
        "run_name_empty": [good, "--run-name", ""],
        "run_name_step": [good, "--run-name", "x_step_99999"],
        "no_motion": [write(tmp_path, "still.csv", [HEADER, *rows(150, value="0.1")])],
        "implausible": [write(tmp_path, "far.csv", [HEADER, *rows(150), "1.50," + ",".join(["5e8"] * 12)])],
    }[case]
    done = joshua("sysid", *arguments, cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1 and done.stderr.startswith("joshua: error: "), done.stderr
    assert expected in done.stderr
    assert not (tmp_path / "joshua_output").exists() or not any((tmp_path / "joshua_output").iterdir())


BARE_MODEL = "<mujoco><worldbody>{}</worldbody></mujoco>".format(
    "".join(f'<body><joint name="{joint}"/><geom size="0.1"/></body>' for joint in JOINTS)
)


def test_recorded_targets_drive_the_same_simulation_the_fit_assumes() -> None:
    """The generator's positions are what the nominal fit machinery predicts for the true model (residual ~ 0),
    so the end-to-end test measures the fit, not a mismatch between generator and fit."""
    spec, servos = true_spec()
    times, positions, targets = synthetic.simulate(spec.compile(), servos, 0, 1.5, RATE_HZ)
    recording = recordings.Recording(Path("memory.csv"), times, positions, targets)
    result = fit.fit(spec, servos, [recording], kinds=("kp",), max_iters=1)
    assert np.max(result.rms_before) < 1e-6
    assert result.identified["joint_1"]["kp"] == pytest.approx(fit.read_value(spec, servos[0], "kp"), rel=1e-3)


def write_stl(path: Path) -> None:
    """A binary STL tetrahedron, 5 cm a side."""
    vertices = [(0, 0, 0), (0.05, 0, 0), (0, 0.05, 0), (0, 0, 0.05)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    triangles = b"".join(
        struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *vertices[i]) for i in face) + b"\0\0"
        for face in faces
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"\0" * 80 + struct.pack("<I", len(faces)) + triangles)


def one_servo_model(tmp_path: Path) -> tuple[Path, Path]:
    """A one-joint model whose meshes lie above its folder and at an absolute path (both named m.stl), and a
    recording of that joint; (model, recording)."""
    write_stl(tmp_path / "elsewhere" / "m.stl")
    write_stl(tmp_path / "abs" / "m.stl")
    model = tmp_path / "model" / "deep" / "er" / "arm.xml"
    model.parent.mkdir(parents=True)
    model.write_text(
        f'<mujoco><asset><mesh name="a" file="../../../elsewhere/m.stl"/><mesh name="b" file="{tmp_path}/abs/m.stl"/>'
        '</asset><worldbody><body><joint name="j" axis="0 0 1" damping="0.1"/><geom type="mesh" mesh="a"/>'
        '<geom type="mesh" mesh="b" pos="0.1 0 0"/></body></worldbody>'
        '<actuator><position name="j_position" joint="j" kp="2"/></actuator></mujoco>'
    )
    lines = [
        f"{i * 0.01:.2f},{0.3 - 0.3 * math.cos(i * 0.05):.4f},{0.3 - 0.3 * math.cos(i * 0.05 + 0.2):.4f}"
        for i in range(200)
    ]
    return model, Path(write(tmp_path, "rec.csv", ["timestamp,j,j.target", *lines]))


def test_meshes_from_outside_the_model_folder_are_copied_inside_the_run(tmp_path: Path) -> None:
    model, recording = one_servo_model(tmp_path)
    outside = {path: path.read_bytes() for path in (tmp_path / "elsewhere" / "m.stl", tmp_path / "abs" / "m.stl")}
    original = model.read_text()
    arguments = [str(recording), "--model", str(model), "--max-iters", "1", "--fit", "kp", "--run-name", "r"]
    done = joshua("sysid", *arguments, "--output-dir", "out", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    run = tmp_path / "out" / "r"
    assert sorted(path.name for path in (run / "assets").iterdir()) == ["m.stl", "m_2.stl"]
    assert sorted(path.name for path in tmp_path.iterdir()) == ["abs", "elsewhere", "model", "out", "rec.csv"]
    assert {path: path.read_bytes() for path in outside} == outside and model.read_text() == original
    assert sorted(path.name for path in model.parent.iterdir()) == ["arm.xml"]
    calibrated = mujoco.MjModel.from_xml_path(str(run / "arm_calibrated.xml"))  # compiles from the run alone
    assert calibrated.nmesh == 2


def test_a_fit_that_fails_while_writing_leaves_no_run_folder(tmp_path: Path, monkeypatch) -> None:
    model, recording = one_servo_model(tmp_path)

    def full(*_: object) -> Path:
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp_path / "out" / "r" / report.REPORT_FILE))

    monkeypatch.setattr(report, "write_report", full)  # after the model, its meshes and the plot are written
    monkeypatch.chdir(tmp_path)
    arguments = [str(recording), "--model", str(model), "--max-iters", "1", "--fit", "kp", "--run-name", "r"]
    assert main(["sysid", *arguments, "--output-dir", "out"]) == 2
    assert list((tmp_path / "out").iterdir()) == []


ONE_JOINT = (
    '<mujoco><worldbody><body><joint name="j" axis="0 0 1" damping="0.1"/><geom size="0.05" pos="0.1 0 0"/></body>'
    '</worldbody><actuator><position name="j_position" joint="j" kp="{kp}" ctrlrange="-1 1"/></actuator></mujoco>'
)


@pytest.mark.parametrize(
    ("fitted", "field", "expected"),
    [
        ("kp,damping", "at_bounds", "j.kp ended at the edge of the search range (0.2x to 5x the nominal value)"),
        ("damping", "poorly_tracked", "still misses the recordings of j by over 10% of their motion"),
    ],
)
def test_a_poor_fit_is_one_warning(tmp_path: Path, capsys, monkeypatch, fitted: str, field: str, expected: str) -> None:
    """The arm's servo is 20 times stiffer than its model's. Fitted, kp stops at 5x and damping bends to make up for
    it, so the tracking error is small and only the bound tells; left out, most of the tracking error stays."""
    model = tmp_path / "arm.xml"
    model.write_text(ONE_JOINT.format(kp=2))
    arm = mujoco.MjModel.from_xml_string(ONE_JOINT.format(kp=40))
    servos = recordings.model_servos(arm, model)
    synthetic.write_csv(tmp_path / "rec.csv", servos, *synthetic.simulate(arm, servos, 0, 2.0, RATE_HZ))
    monkeypatch.chdir(tmp_path)
    arguments = ["rec.csv", "--model", str(model), "--fit", fitted, "--output-dir", "out", "--run-name", "r"]
    assert main(["sysid", *arguments]) == 0
    [warning] = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert warning.startswith("joshua: warning: poor fit: ") and expected in warning, warning
    assert json.loads((tmp_path / "out" / "r" / report.REPORT_FILE).read_text())["fit"][field] == [
        "j.kp" if field == "at_bounds" else "j"
    ]


def test_a_name_a_dead_run_held_is_taken_over_and_a_failed_fit_leaves_no_folder(
    tmp_path: Path, capsys, monkeypatch
) -> None:
    model, recording = one_servo_model(tmp_path)
    ended = subprocess.Popen([sys.executable, "-c", ""])
    ended.wait()
    (tmp_path / "out" / "r").mkdir(parents=True)
    (tmp_path / "out" / "r" / LOCK_FILE).write_text(f"{ended.pid}\n")  # what a run killed while starting leaves
    monkeypatch.chdir(tmp_path)
    arguments = [str(recording), "--model", str(model), "--max-iters", "1", "--fit", "kp", "--output-dir", "out"]
    assert main(["sysid", *arguments, "--run-name", "r"]) == 0
    assert f"held only the lock of process {ended.pid}, which ended before writing anything" in capsys.readouterr().err
    assert (tmp_path / "out" / "r" / report.REPORT_FILE).is_file()

    def interrupted(*_: object) -> fit.FitResult:
        raise KeyboardInterrupt  # Ctrl-C during the fit, in the run folder it claimed first

    monkeypatch.setattr(fit, "fit", interrupted)
    assert main(["sysid", *arguments, "--run-name", "s"]) == 130
    assert [path.name for path in (tmp_path / "out").iterdir()] == ["r"]


def test_max_iters_runs_exactly_that_many_iterations(tmp_path: Path) -> None:
    model, recording = one_servo_model(tmp_path)
    arguments = [str(recording), "--model", str(model), "--max-iters", "3", "--fit", "kp,damping", "--run-name", "r"]
    done = joshua("sysid", *arguments, "--output-dir", "out", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "after 3 iterations" in done.stdout


def test_a_recording_that_does_not_start_at_rest_is_one_line(tmp_path: Path) -> None:
    model, _ = one_servo_model(tmp_path)
    lines = [f"{i * 0.01:.2f},{0.3 * math.sin(i * 0.05):.4f},{0.3 * math.sin(i * 0.05):.4f}" for i in range(200)]
    moving = write(tmp_path, "moving.csv", ["timestamp,j,j.target", *lines])
    done = joshua("sysid", moving, "--model", str(model), "--output-dir", "out", cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.strip().count("\n") == 0 and "does not start at rest: joint 'j' moves at 1.5" in done.stderr


def test_episode_picks_the_dataset_episode_and_checks_it_starts_at_rest(tmp_path: Path) -> None:
    """A LeRobot dataset whose episode 0 starts moving and episode 1 at rest: --episode 1 fits, 0 is refused."""
    writer = pytest.importorskip("joshua_lerobot.writer")
    model, _ = one_servo_model(tmp_path)
    times = np.arange(200) * 0.01
    episodes = []
    for moving in (True, False):  # sin from its steepest point, then 1 - cos from a standstill
        positions = (0.3 * np.sin(times * 5) if moving else 0.3 - 0.3 * np.cos(times * 5))[:, None]
        episodes.append(writer.DatasetEpisode(("j",), times, positions, positions, task="wave"))
    writer.write_dataset(tmp_path / "data", episodes, fps=100, joint_ranges={"j": (-math.inf, math.inf)})
    common = ["--model", str(model), "--max-iters", "1", "--fit", "kp", "--output-dir", "out"]
    assert joshua("sysid", "data", *common, "--episode", "1", "--run-name", "e1", cwd=tmp_path).returncode == 0
    refused = joshua("sysid", "data", *common, "--run-name", "e0", cwd=tmp_path)
    assert refused.returncode == 2 and "does not start at rest" in refused.stderr, refused.stderr
    missing = joshua("sysid", "data", *common, "--episode", "2", cwd=tmp_path)
    assert missing.returncode == 2 and "no episode 2" in missing.stderr
