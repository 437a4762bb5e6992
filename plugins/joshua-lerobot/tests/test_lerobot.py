"""LeRobot datasets against the real `lerobot` (0.4.4 on Python 3.11, 0.6 on 3.12): ours load in `LeRobotDataset`
(frames, values, decoded video), and one written by lerobot's own writer replays and validates through
`load_trajectory` and PASSIVE.

lerobot runs in a subprocess (tests/lerobot_side.py, started by tests/lerobot_harness.py) over the pinned packages
`./setup.sh --dev` installs beside the venv (tests/lerobot-requirements*.txt): they must not change it.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from lerobot_harness import LEROBOT_SITE, PYTHON_VERSION, lerobot, lerobot_version, pinned_lerobot_version

from joshua_core.plugins import PluginHost
from joshua_core.resources import models_dir
from joshua_core.trajectory import Trajectory, TrajectoryError, write_trajectory
from joshua_core.trajectory_sources import load_trajectory
from joshua_lerobot import export_trajectory
from joshua_lerobot.writer import DatasetEpisode, write_dataset
from joshua_modes import iter_offscreen_frames, model_joint_ranges
from joshua_mujoco import compile_model

MODEL = models_dir() / "so_arm100" / "scene.xml"
JOINTS = tuple(f"joint_{i}" for i in range(1, 7))
FPS = 10
PLUGINS = PluginHost.discover()  # the installed plugins: their readers read the datasets
WIDTH, HEIGHT = 64, 48


@pytest.fixture(scope="module")
def ranges() -> dict[str, tuple[float, float]]:
    return model_joint_ranges(compile_model(MODEL))


def motion(ranges: dict[str, tuple[float, float]]) -> Trajectory:
    """1.5 s of smooth motion inside every joint's range, with targets leading the positions by 50 ms."""
    times = np.linspace(0.0, 1.5, 31)
    mids = np.array([(ranges[j][0] + ranges[j][1]) / 2 for j in JOINTS])
    spans = np.array([ranges[j][1] - ranges[j][0] for j in JOINTS])

    def at(t: np.ndarray) -> np.ndarray:
        return mids + 0.25 * spans * np.sin(2 * t[:, None] + np.arange(6))

    return Trajectory(Path("motion.csv"), JOINTS, times, at(times), np.arange(31), at(times + 0.05))


def test_the_lerobot_tested_is_the_one_pinned_for_this_python() -> None:
    """The site setup.sh installed holds this Python's pin (0.4.4 on 3.11, 0.6 on 3.12), not a stale one: the
    pytest header names it too (conftest.py)."""
    assert lerobot_version() == pinned_lerobot_version(), (
        f"{LEROBOT_SITE} on Python {PYTHON_VERSION}: run ./setup.sh --dev"
    )


def test_our_dataset_loads_in_lerobot(tmp_path: Path, ranges: dict[str, tuple[float, float]]) -> None:
    csv = tmp_path / "motion.csv"
    trajectory = motion(ranges)
    write_trajectory(csv, trajectory)
    root = export_trajectory(
        csv, MODEL, tmp_path / "dataset", fps=FPS, size=(WIDTH, HEIGHT), task="wave", plugins=PLUGINS
    )
    loaded = lerobot("load", root, tmp_path)

    frames = 16  # 1.5 s at 10 fps, both ends
    assert (loaded["frames"], loaded["episodes"], loaded["fps"]) == (frames, 1, FPS)
    assert loaded["task"] == ["wave"] * frames
    assert np.allclose(loaded["timestamp"], np.arange(frames) / FPS, atol=1e-6)
    times = np.arange(frames) / FPS
    degrees = np.degrees  # SO-100 arm joints: degrees from the middle of the range; gripper 0..100
    low, high = ranges["joint_6"]
    for key, values in (("state", trajectory.positions), ("action", trajectory.targets)):
        expected = np.stack([np.interp(times, trajectory.timestamps, column) for column in values.T], axis=1)
        mids = np.array([(ranges[j][0] + ranges[j][1]) / 2 for j in JOINTS[:5]])
        arm = degrees(expected[:, :5] - mids)
        gripper = (expected[:, 5] - low) / (high - low) * 100
        assert np.allclose(np.array(loaded[key]), np.column_stack([arm, gripper]), atol=1e-3), key

    (camera,) = loaded["cameras"].values()
    assert camera["shape"] == [3, HEIGHT, WIDTH]
    frames = iter_offscreen_frames(MODEL, csv, WIDTH, HEIGHT, fps=FPS, plugins=PLUGINS)
    rendered = [frame.mean() / 255 for frame in frames]
    assert np.allclose(camera["mean"], rendered, atol=0.02)  # each decoded frame is the one rendered


def test_lerobot_dataset_replays_and_validates(tmp_path: Path, ranges: dict[str, tuple[float, float]]) -> None:
    root = tmp_path / "recorded"
    written = lerobot("write", root, tmp_path)
    low, high = ranges["joint_6"]
    for episode, expected in enumerate(written["episodes"]):
        trajectory = load_trajectory(root, ranges, episode=episode, plugins=PLUGINS)
        assert trajectory.joint_names == JOINTS
        assert np.allclose(trajectory.timestamps, np.arange(len(expected["state"])) / written["fps"], atol=1e-6)
        for values, lerobot_values in (
            (trajectory.positions, expected["state"]),
            (trajectory.targets, expected["action"]),
        ):
            source = np.array(lerobot_values)
            assert values is not None
            assert np.allclose(values[:, :5], np.radians(source[:, :5]), atol=1e-6)  # ranges are symmetric about 0
            assert np.allclose(values[:, 5], low + source[:, 5] / 100 * (high - low), atol=1e-6)

    output = tmp_path / "out"
    command = [
        sys.executable, "-m", "joshua_core.cli", "--preset", "sim_passive", "--strict",
        "--set", f"simulation.trajectory_path={root}", "--episode", "1",
        "--set", f"simulation.output_dir={output}", "--set", "simulation.viewer.display=RECORD",
        "--set", "simulation.viewer.fps=5",
        "--set", "simulation.render_width=64", "--set", "simulation.render_height=48",
    ]  # fmt: skip
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    report = json.loads((output / "passive_report.json").read_text())
    assert report["ok"], report["issues"]
    assert report["rows"] == report["replayed_rows"] == len(written["episodes"][1]["state"])
    assert (output / "passive_replay.mp4").stat().st_size > 0


def test_bad_datasets_and_episodes_are_one_line_errors(tmp_path: Path) -> None:
    out = tmp_path / "dataset"
    export = [str(Path(sys.executable).parent / "joshua"), "lerobot-export"]
    csv = models_dir() / "trajectories" / "so_arm100_example.csv"
    made = subprocess.run(
        [*export, str(csv), "--out", str(out), "--no-video", "--fps", "5"], capture_output=True, text=True
    )
    assert made.returncode == 0, made.stderr
    replay = [
        str(Path(sys.executable).parent / "joshua"),
        "--preset",
        "sim_passive",
        "--set",
        f"simulation.trajectory_path={out}",
    ]
    result = subprocess.run([*replay, "--set", "simulation.replay.episode=4"], capture_output=True, text=True)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert f"{out}: no episode 4; the dataset has episodes 0..0 (1)" in result.stderr
    info = out / "meta" / "info.json"
    info.write_text(info.read_text().replace('"v3.0"', '"v2.1"'))
    result = subprocess.run(replay, capture_output=True, text=True)
    assert result.returncode == 2 and "LeRobot dataset format v2.1, this reader reads v3.0" in result.stderr


def test_out_replaces_only_a_dataset_joshua_wrote_and_only_with_overwrite(tmp_path: Path) -> None:
    joshua = str(Path(sys.executable).parent / "joshua")
    csv = str(models_dir() / "trajectories" / "so_arm100_example.csv")

    def export(out: str, *extra: str) -> subprocess.CompletedProcess[str]:
        command = [joshua, "lerobot-export", csv, "--out", out, "--no-video", "--fps", "5", *extra]
        return subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=300)

    def refused(done: subprocess.CompletedProcess[str], message: str) -> None:
        assert done.returncode == 2 and done.stderr.strip().count("\n") == 0 and message in done.stderr, done.stderr

    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    (tmp_path / "file").write_text("keep")
    for extra in ((), ("--overwrite",)):
        refused(export("mine", *extra), "was not written by joshua")
        refused(export("file", *extra), "is a file")
        refused(export(".", *extra), "names no folder of its own")
    assert (mine / "notes.txt").read_text() == "keep" and (tmp_path / "file").read_text() == "keep"

    assert export("dataset").returncode == 0
    refused(export("dataset"), "exists; pass --overwrite")
    (tmp_path / "dataset" / "meta" / "info.json").write_text("{}")
    done = export("dataset", "--overwrite")
    assert done.returncode == 0, done.stderr
    assert json.loads((tmp_path / "dataset" / "meta" / "info.json").read_text())["fps"] == 5  # written anew
    assert sorted(path.name for path in tmp_path.iterdir()) == ["dataset", "file", "mine"]  # no temporaries left


DATA = "data/chunk-000/file-000.parquet"
EPISODES = "meta/episodes/chunk-000/file-000.parquet"
INFO = "meta/info.json"
STATE = "observation.state"


@pytest.fixture(scope="module")
def valid_dataset(tmp_path_factory: pytest.TempPathFactory, ranges: dict[str, tuple[float, float]]) -> Path:
    """A small valid dataset (no video) written by joshua's own writer; each case copies and damages it."""
    trajectory = motion(ranges)
    episode = DatasetEpisode(JOINTS, trajectory.timestamps, trajectory.positions, trajectory.targets, "wave")
    root = tmp_path_factory.mktemp("valid") / "dataset"
    write_dataset(root, [episode], fps=FPS, joint_ranges=ranges)
    return root


def edit_info(**changes: Any) -> Any:
    """A damage that sets top-level fields of info.json (None deletes)."""

    def damage(root: Path) -> None:
        info = json.loads((root / INFO).read_text())
        for key, value in changes.items():
            if value is None:
                info.pop(key)
            else:
                info[key] = value
        (root / INFO).write_text(json.dumps(info))

    return damage


def edit_state_feature(**changes: Any) -> Any:
    """A damage that sets fields of info.json's observation.state feature (and action's, which must agree)."""

    def damage(root: Path) -> None:
        info = json.loads((root / INFO).read_text())
        for key in (STATE, "action"):
            info["features"][key] |= changes
        (root / INFO).write_text(json.dumps(info))

    return damage


def write_bytes(file: str, cut: float | bytes) -> Any:
    """A damage that truncates `file` to the fraction `cut` of its bytes, or replaces them by `cut`."""

    def damage(root: Path) -> None:
        data = (root / file).read_bytes()
        (root / file).write_bytes(cut if isinstance(cut, bytes) else data[: int(len(data) * cut)])

    return damage


def edit_table(file: str, change: Any) -> Any:
    """A damage that rewrites parquet `file` as `change(columns)` (a dict of Python lists, edited in place)."""

    def damage(root: Path) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        columns = pq.read_table(root / file).to_pydict()
        change(columns)
        pq.write_table(pa.table(columns), root / file)

    return damage


def link_data_outside(root: Path) -> None:
    outside = root.parent / "outside.parquet"
    (root / DATA).rename(outside)
    (root / DATA).symlink_to(outside)


def state_rows(change: Any) -> Any:
    """A damage that replaces each row of observation.state by `change(row index, row)`."""
    return edit_table(DATA, lambda c: c.__setitem__(STATE, [change(i, row) for i, row in enumerate(c[STATE])]))


NAMES = ["shoulder_pan.pos", "shoulder_lift.pos", "elbow_flex.pos", "wrist_flex.pos", "wrist_roll.pos", "gripper.pos"]
# (case, damage, file the message names, what else it says)
MALFORMED = [
    ("info not JSON", write_bytes(INFO, b"{"), INFO, "cannot read the dataset's info"),
    ("info a list", write_bytes(INFO, b"[]"), INFO, "holds a JSON array, not an object"),
    ("info nested deeply", write_bytes(INFO, b"[" * 100_000 + b"]" * 100_000), INFO, "info: nested too deeply"),
    ("features a list", edit_info(features=[]), INFO, "'features' is missing or not an object"),
    ("no state feature", edit_info(features={}), INFO, f"features.{STATE} is missing or not an object"),
    ("names a string", edit_state_feature(names="abc"), INFO, f"features.{STATE}.names is not a non-empty list"),
    ("names numbers", edit_state_feature(names=list(range(6))), INFO, f"features.{STATE}.names is not"),
    ("shape disagrees", edit_state_feature(shape=[7]), INFO, f"features.{STATE}.shape is [7], but it names 6"),
    ("data_path missing", edit_info(data_path=None), INFO, "'data_path' is missing or not a string"),
    ("data_path a number", edit_info(data_path=5), INFO, "'data_path' is missing or not a string"),
    ("data_path absolute", edit_info(data_path="/etc/passwd"), INFO, "leads outside the dataset folder"),
    ("data_path climbs out", edit_info(data_path="../../../etc/passwd"), INFO, "leads outside the dataset folder"),
    ("data file a link out", link_data_outside, INFO, "leads outside the dataset folder"),
    ("data_path other field", edit_info(data_path="data/{episode}.parquet"), INFO, "uses episode; it may use only"),
    ("data_path bad format", edit_info(data_path="data/{chunk_index:zz}"), INFO, "is not a path template"),
    ("data file empty", write_bytes(DATA, b""), DATA, "not a readable parquet file"),
    ("data file garbage", write_bytes(DATA, b"PAR1 garbage PAR1"), DATA, "not a readable parquet file"),
    ("data file truncated", write_bytes(DATA, 0.5), DATA, "not a readable parquet file"),
    ("episodes garbage", write_bytes(EPISODES, b"not parquet"), EPISODES, "not a readable parquet file"),
    ("episodes empty", edit_table(EPISODES, lambda c: [v.clear() for v in c.values()]), "meta/episodes", "no episode"),
    ("episodes no length", edit_table(EPISODES, lambda c: c.pop("length")), EPISODES, "no column 'length'"),
    (
        "episodes negative",
        edit_table(EPISODES, lambda c: c.__setitem__("data/file_index", [-1])),
        EPISODES,
        "column 'data/file_index' holds -1, expected an integer >= 0",
    ),
    ("no state column", edit_table(DATA, lambda c: c.pop(STATE)), DATA, f"no column '{STATE}'"),
    ("no timestamp column", edit_table(DATA, lambda c: c.pop("timestamp")), DATA, "no column 'timestamp'"),
    (
        "timestamps text",
        edit_table(DATA, lambda c: c.__setitem__("timestamp", [str(t) for t in c["timestamp"]])),
        DATA,
        "column 'timestamp' is string",
    ),
    (
        "zero rows",
        edit_table(DATA, lambda c: c.__setitem__("episode_index", [7] * len(c["episode_index"]))),
        DATA,
        "episode 0 has no frames",
    ),
    ("ragged state", state_rows(lambda i, row: row[: 5 if i % 2 else 6]), DATA, "rows of different widths (5, 6)"),
    ("state too narrow", state_rows(lambda i, row: row[:5]), DATA, f"'{STATE}' is 5 wide, but {INFO}"),
    ("state too wide", state_rows(lambda i, row: [*row, 0.0, 0.0]), DATA, f"'{STATE}' is 8 wide, but {INFO}"),
    (
        "5 names for 6 columns",
        edit_state_feature(names=NAMES[:5], shape=[5]),
        DATA,
        f"'{STATE}' is 6 wide, but {INFO} features.{STATE}.names has 5 joints",
    ),
    ("state text", state_rows(lambda i, row: [str(v) for v in row]), DATA, "expected a list of numbers per row"),
    ("state null row", state_rows(lambda i, row: None if i == 2 else row), DATA, "has an empty (null) row"),
    (
        "state NaN",
        state_rows(lambda i, row: [float("nan")] + row[1:] if i == 3 else row),
        DATA,
        "joint 'shoulder_pan.pos' has nan at frame 3: not a finite value within ±10000",
    ),
    (
        "state 1e30 degrees",
        state_rows(lambda i, row: row[:2] + [1e30] + row[3:] if i == 4 else row),
        DATA,
        "joint 'elbow_flex.pos' has 1e+30 at frame 4: not a finite value within ±10000",
    ),
]


def damaged(valid_dataset: Path, tmp_path: Path, damage: Any) -> Path:
    root = tmp_path / "dataset"
    shutil.copytree(valid_dataset, root)
    damage(root)
    return root


def test_the_valid_dataset_reads(valid_dataset: Path, ranges: dict[str, tuple[float, float]]) -> None:
    trajectory = load_trajectory(valid_dataset, ranges, plugins=PLUGINS)
    assert trajectory.joint_names == JOINTS and trajectory.rows == len(motion(ranges).timestamps)
    assert trajectory.targets is not None


@pytest.mark.parametrize(("damage", "file", "message"), [case[1:] for case in MALFORMED], ids=[c[0] for c in MALFORMED])
def test_a_malformed_dataset_is_one_line_naming_its_file_and_field(
    valid_dataset: Path, tmp_path: Path, ranges: dict[str, tuple[float, float]], damage: Any, file: str, message: str
) -> None:
    root = damaged(valid_dataset, tmp_path, damage)
    with pytest.raises(TrajectoryError) as raised:
        load_trajectory(root, ranges, plugins=PLUGINS)
    text = str(raised.value)
    assert "\n" not in text and text.startswith(str(root / file)) and message in text, text


@pytest.mark.parametrize(
    "case", ["data_path absolute", "data file truncated", "5 names for 6 columns", "info nested deeply"]
)
def test_the_cli_reports_a_malformed_dataset_in_one_line(valid_dataset: Path, tmp_path: Path, case: str) -> None:
    damage, file, message = next(entry[1:] for entry in MALFORMED if entry[0] == case)
    root = damaged(valid_dataset, tmp_path, damage)
    joshua = str(Path(sys.executable).parent / "joshua")
    command = [joshua, "--preset", "sim_passive", "--set", f"simulation.trajectory_path={root}"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 2 and done.stderr.strip().count("\n") == 0, done.stderr
    assert str(root / file) in done.stderr and message in done.stderr, done.stderr


def test_several_recordings_export_as_one_dataset_with_a_task_each(
    tmp_path: Path, ranges: dict[str, tuple[float, float]]
) -> None:
    first, second = tmp_path / "a.csv", tmp_path / "b.csv"
    write_trajectory(first, motion(ranges))
    shorter = motion(ranges)
    keep = shorter.timestamps <= 1.0
    write_trajectory(
        second,
        Trajectory(second, JOINTS, shorter.timestamps[keep], shorter.positions[keep], np.arange(keep.sum())),
    )
    joshua = str(Path(sys.executable).parent / "joshua")
    out = tmp_path / "both"
    common = [joshua, "lerobot-export", str(first), str(second), "--out", str(out), "--no-video", "--fps", str(FPS)]
    done = subprocess.run([*common, "--task", "wave", "--task", "point"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    loaded = lerobot("load", out, tmp_path)
    assert (loaded["frames"], loaded["episodes"]) == (16 + 11, 2)  # 1.5 s and 1.0 s at 10 fps, both ends
    assert loaded["task"] == ["wave"] * 16 + ["point"] * 11
    assert [load_trajectory(out, ranges, episode=e, plugins=PLUGINS).rows for e in (0, 1)] == [16, 11]

    wrong = subprocess.run(
        [*common, "--overwrite", "--task", "a", "--task", "b", "--task", "c"], capture_output=True, text=True
    )
    assert wrong.returncode == 2 and wrong.stderr.count("\n") == 1
    assert "--task is given 3 times for 2 trajectories" in wrong.stderr


MOTORS = [name.removesuffix(".pos") for name in NAMES]
# An SO-100 calibration as lerobot-calibrate writes it: ranges off-centre and of different widths, the wrist
# roll a full turn (as SOFollower.calibrate sets it), the elbow with its drive mode set.
CALIBRATION = {
    motor: {"id": i + 1, "drive_mode": int(motor == "elbow_flex"), "homing_offset": 100 * i - 250,
            "range_min": low, "range_max": high}
    for i, (motor, (low, high)) in enumerate(
        zip(MOTORS, [(820, 3300), (900, 3150), (880, 3100), (870, 3200), (0, 4095), (2010, 3400)], strict=True)
    )
}  # fmt: skip
OFFSETS = {"joint_1": 0.05, "joint_3": -0.1, "joint_6": 0.02}
ROUND_TRIP_TOLERANCE = 1e-9  # rad: float64 arithmetic only


def calibration_file(tmp_path: Path) -> Path:
    path = tmp_path / "so100_follower_arm.json"
    path.write_text(json.dumps(CALIBRATION, indent=4))
    return path


def all_units(tmp_path: Path) -> dict[str, Any]:
    from joshua_lerobot.joints import BodyUnits, LeRobotUnits, read_calibration

    calibration = read_calibration(calibration_file(tmp_path))
    return {
        "degrees": LeRobotUnits(),
        "degrees, calibrated": LeRobotUnits(BodyUnits.DEGREES, calibration, OFFSETS),
        "range": LeRobotUnits(BodyUnits.RANGE, calibration),
        "range, offsets": LeRobotUnits(BodyUnits.RANGE, calibration, OFFSETS),
    }


def test_radians_to_lerobot_units_and_back_in_both_modes(
    tmp_path: Path, ranges: dict[str, tuple[float, float]]
) -> None:
    rng = np.random.default_rng(0)
    for label, units in all_units(tmp_path).items():
        for name, joint in zip(NAMES, JOINTS, strict=True):
            low, high = ranges[joint]
            q = rng.uniform(low, high, 200)
            values = units.from_model(name, q, ranges[joint])
            assert np.allclose(units.to_model(name, values, ranges[joint]), q, rtol=0, atol=ROUND_TRIP_TOLERANCE), label


def test_lerobot_motor_bus_values_map_to_the_same_radians_in_both_modes(
    tmp_path: Path, ranges: dict[str, tuple[float, float]]
) -> None:
    from joshua_lerobot.joints import BodyUnits, LeRobotUnits, read_calibration

    ticks = {motor: np.linspace(e["range_min"], e["range_max"], 9).round().tolist() for motor, e in CALIBRATION.items()}
    request = tmp_path / "normalize.json"
    request.write_text(json.dumps({"calibration": CALIBRATION, "ticks": ticks}))
    read = lerobot("normalize", request, tmp_path)
    calibration = read_calibration(calibration_file(tmp_path))
    degrees, in_range = LeRobotUnits(BodyUnits.DEGREES, calibration), LeRobotUnits(BodyUnits.RANGE, calibration)
    tick = 2 * np.pi / 4095  # rad: lerobot's degree is 4095 / 360 ticks
    for motor, name, joint in zip(MOTORS, NAMES, JOINTS, strict=True):
        entry, low_high = CALIBRATION[motor], ranges[joint]
        middle = (entry["range_min"] + entry["range_max"]) / 2
        # the arm's angle from the middle of its calibrated range, the model's middle there
        expected = sum(low_high) / 2 + (np.array(ticks[motor]) - middle) * tick
        from_degrees = degrees.to_model(name, np.array(read["True"][motor]), low_high)
        from_range = in_range.to_model(name, np.array(read["False"][motor]), low_high)
        assert np.allclose(from_degrees, expected, rtol=0, atol=1e-9), motor
        assert np.allclose(from_range, expected, rtol=0, atol=1e-9), motor


@pytest.mark.parametrize("label", ["degrees, calibrated", "range, offsets"])
def test_a_dataset_in_each_mode_loads_in_lerobot_and_reads_back(
    tmp_path: Path, ranges: dict[str, tuple[float, float]], label: str
) -> None:
    units = all_units(tmp_path)[label]
    trajectory = motion(ranges)
    episode = DatasetEpisode(JOINTS, trajectory.timestamps, trajectory.positions, trajectory.targets, "wave")
    root = write_dataset(tmp_path / "dataset", [episode], fps=FPS, joint_ranges=ranges, units=units)
    loaded = lerobot("load", root, tmp_path)
    for key, values in (("state", trajectory.positions), ("action", trajectory.targets)):
        expected = np.column_stack(
            [units.from_model(name, values[:, i], ranges[JOINTS[i]]) for i, name in enumerate(NAMES)]
        )
        assert np.allclose(np.array(loaded[key]), expected, rtol=0, atol=1e-3), key  # float32 of values <= 180
    read = load_trajectory(root, ranges, plugins=PLUGINS)
    assert read.targets is not None
    assert np.allclose(read.positions, trajectory.positions, rtol=0, atol=1e-5)  # rad: float32 in LeRobot units
    assert np.allclose(read.targets, trajectory.targets, rtol=0, atol=1e-5)


def test_export_in_range_units_needs_the_calibration(tmp_path: Path) -> None:
    joshua = str(Path(sys.executable).parent / "joshua")
    csv = str(models_dir() / "trajectories" / "so_arm100_example.csv")
    export = [joshua, "lerobot-export", csv, "--no-video", "--fps", "5", "--units", "range"]
    missing = subprocess.run([*export, "--out", str(tmp_path / "a")], capture_output=True, text=True, timeout=300)
    assert missing.returncode == 2 and missing.stderr.count("\n") == 1, missing.stderr
    assert "need the arm's calibration" in missing.stderr and not (tmp_path / "a").exists()
    broken = tmp_path / "broken.json"
    broken.write_text(json.dumps({motor: entry for motor, entry in CALIBRATION.items() if motor != "gripper"}))
    refused = subprocess.run(
        [*export, "--out", str(tmp_path / "b"), "--calibration", str(broken)], capture_output=True, text=True
    )
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1
    assert f"{broken}: the LeRobot calibration has no motor gripper" in refused.stderr

    config = tmp_path / "arm.pbtxt"
    config.write_text(
        'extends: "sim_mirror"\nsimulation { mirror_topic_mappings {\n'
        + "".join(
            f'  mappings {{ ros_topic: "/enc/{j}" mujoco_actuator: "{j}_position" offset: {OFFSETS.get(j, 0.0)} }}\n'
            for j in JOINTS
        )
        + "} }\n"
    )
    out = tmp_path / "c"
    done = subprocess.run(
        [*export, "--out", str(out), "--calibration", str(calibration_file(tmp_path)), "--config", str(config)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    recorded = json.loads((out / INFO).read_text())["features"][STATE]["units"]
    assert recorded["body"] == "range" and recorded["offsets"] == pytest.approx(
        {j: OFFSETS.get(j, 0.0) for j in JOINTS}
    )  # float32 in the config
    assert recorded["calibration"]["elbow_flex"] == {"range_min": 880, "range_max": 3100, "drive_mode": 1}


def joshua_units(root: Path, *options: str) -> subprocess.CompletedProcess[str]:
    """`joshua lerobot-units ROOT OPTIONS...`."""
    command = [str(Path(sys.executable).parent / "joshua"), "lerobot-units", str(root), *options]
    return subprocess.run(command, capture_output=True, text=True, timeout=300)


@pytest.mark.slow
def test_a_dataset_lerobot_recorded_in_range_units_reads_once_its_units_are_recorded(
    tmp_path: Path, ranges: dict[str, tuple[float, float]], capsys: pytest.CaptureFixture[str]
) -> None:
    from joshua_lerobot.joints import BodyUnits, LeRobotUnits, read_calibration

    root = tmp_path / "recorded"
    written = lerobot("write", root, tmp_path)  # as a use_degrees=False follower: body -100..100, gripper 0..100
    refused = joshua_units(root, "--units", "range")
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1 and "calibration" in refused.stderr
    done = joshua_units(root, "--units", "range", "--calibration", str(calibration_file(tmp_path)))
    assert done.returncode == 0, done.stderr
    units = LeRobotUnits(BodyUnits.RANGE, read_calibration(calibration_file(tmp_path)))
    for episode, expected in enumerate(written["episodes"]):
        trajectory = load_trajectory(root, ranges, episode=episode, plugins=PLUGINS)
        source = np.array(expected["state"])
        converted = np.column_stack([units.to_model(n, source[:, i], ranges[JOINTS[i]]) for i, n in enumerate(NAMES)])
        assert np.allclose(trajectory.positions, converted, rtol=0, atol=1e-6)  # rad
        assert not np.allclose(trajectory.positions[:, :5], np.radians(source[:, :5]), atol=1e-3)  # not degrees
    assert "hint" not in capsys.readouterr().err
    loaded = lerobot("load", root, tmp_path)  # lerobot still loads it, values untouched
    assert np.allclose(loaded["state"], [row for e in written["episodes"] for row in e["state"]], atol=1e-6)


def test_range_values_read_as_degrees_give_a_one_line_hint(
    tmp_path: Path, ranges: dict[str, tuple[float, float]], capsys: pytest.CaptureFixture[str]
) -> None:
    from joshua_lerobot.joints import BodyUnits, LeRobotUnits, read_calibration

    narrow = dict(CALIBRATION, wrist_flex=dict(CALIBRATION["wrist_flex"], range_min=1200, range_max=2900))
    calibration = tmp_path / "narrow.json"
    calibration.write_text(json.dumps(narrow))
    units = LeRobotUnits(BodyUnits.RANGE, read_calibration(calibration))
    trajectory = motion(ranges)
    positions = trajectory.positions.copy()
    positions[:, 3] = 1.28 * np.sin(np.linspace(0, np.pi, len(positions)))  # wrist_flex up to 98.5 of 100
    episode = DatasetEpisode(JOINTS, trajectory.timestamps, positions, positions, "wave")
    root = write_dataset(tmp_path / "dataset", [episode], fps=FPS, joint_ranges=ranges, units=units)
    info = json.loads((root / INFO).read_text())
    for feature in info["features"].values():
        feature.pop("units", None)  # as lerobot writes it: no record of use_degrees
    (root / INFO).write_text(json.dumps(info))
    capsys.readouterr()
    load_trajectory(root, ranges, plugins=PLUGINS)
    hint = capsys.readouterr().err
    assert hint.count("\n") == 1 and "wrist_flex.pos leave their joint range read as degrees" in hint, hint
    assert f"joshua lerobot-units {root} --units range" in hint
    assert joshua_units(root, "--units", "range", "--calibration", str(calibration)).returncode == 0
    read = load_trajectory(root, ranges, plugins=PLUGINS)
    assert np.allclose(read.positions, positions, rtol=0, atol=1e-5)  # rad: float32 in LeRobot units
    assert "hint" not in capsys.readouterr().err


def test_lerobot_units_keeps_a_record_it_did_not_make_unless_told_to_overwrite(
    tmp_path: Path, ranges: dict[str, tuple[float, float]], capsys: pytest.CaptureFixture[str]
) -> None:
    from joshua_core.cli import main
    from joshua_lerobot.joints import BodyUnits, LeRobotUnits, read_calibration

    calibration = calibration_file(tmp_path)
    ours = LeRobotUnits(BodyUnits.RANGE, read_calibration(calibration), OFFSETS)  # the mirror's offsets recorded
    trajectory = motion(ranges)
    episode = DatasetEpisode(JOINTS, trajectory.timestamps, trajectory.positions, trajectory.positions, "wave")
    root = write_dataset(tmp_path / "dataset", [episode], fps=FPS, joint_ranges=ranges, units=ours)
    written = (root / INFO).read_bytes()
    stray = root / "meta" / "info.json.tmp"  # the name the command once wrote through (and moved away)
    stray.write_text("the user's")
    capsys.readouterr()
    assert main(["lerobot-units", str(root), "--units", "degrees"]) == 2
    error = capsys.readouterr().err
    assert error == (
        f"joshua: error: {root / INFO} already records SO-100 body joints in range, calibrated, with offsets; "
        "pass --overwrite to replace that record\n"
    )
    assert (root / INFO).read_bytes() == written
    assert main(["lerobot-units", str(root), "--units", "degrees", "--overwrite"]) == 0
    assert capsys.readouterr().out == f"{root / INFO}: SO-100 body joints in degrees\n"
    assert main(["lerobot-units", str(root), "--units", "degrees"]) == 0  # the same record again: nothing to do
    assert capsys.readouterr().out == f"{root / INFO}: SO-100 body joints in degrees (recorded already; unchanged)\n"
    assert json.loads((root / INFO).read_text())["features"][STATE]["units"] == {
        "body": "degrees", "calibration": None, "offsets": {}
    }  # fmt: skip
    assert stray.read_text() == "the user's"
    assert not [file for file in (root / "meta").iterdir() if file.name.startswith(".")]  # no temporary left
