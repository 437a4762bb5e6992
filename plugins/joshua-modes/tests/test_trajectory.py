"""The CSV reader and the validation report: every bad input gets a message with its file line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from modes_testing import HEADER, SCENE, SMALL, example_rows

from joshua_core.trajectory import TrajectoryError, read_trajectory
from joshua_modes.replay import model_joint_names
from joshua_modes.validation import line_times, validate
from joshua_mujoco import MuJoCoEngine

HOME = "0.0,-0.35,0.35,1.0,0.0,0.4"


@pytest.fixture(scope="module")
def engine() -> MuJoCoEngine:
    engine = MuJoCoEngine(SCENE)
    engine.reset("home")
    return engine


def check(engine: MuJoCoEngine, path: Path):
    trajectory = read_trajectory(path, model_joint_names(engine.model))
    return validate(trajectory, engine.model, engine.data.qpos.copy())


def test_reads_the_example_with_comments_and_line_numbers(engine: MuJoCoEngine, tmp_path: Path) -> None:
    trajectory = read_trajectory(SCENE.parent.parent / "trajectories" / "so_arm100_example.csv")
    assert trajectory.joint_names == tuple(f"joint_{i}" for i in range(1, 7))
    assert trajectory.rows == 3051
    assert trajectory.lines[0] == 7  # six comment/header lines come first
    report, usable = validate(trajectory, engine.model, engine.data.qpos.copy())
    assert report.ok and usable.all(), report.summary()


def test_columns_match_joints_by_name_in_any_order_and_subsets(engine, write_csv) -> None:
    path = write_csv(["joint_3,timestamp,joint_1", "0.5,0.0,0.1", "0.6,0.1,0.2"])
    trajectory = read_trajectory(path, model_joint_names(engine.model))
    assert trajectory.joint_names == ("joint_3", "joint_1")
    assert trajectory.positions.tolist() == [[0.5, 0.1], [0.6, 0.2]]
    assert trajectory.timestamps.tolist() == [0.0, 0.1]


def test_target_columns_are_read_beside_their_joints(engine, write_csv) -> None:
    path = write_csv(
        ["joint_1.target,timestamp,joint_3,joint_1,joint_3.target", "0.2,0.0,0.5,0.1,0.6", "0.3,0.1,0.6,0.2,0.7"]
    )
    trajectory = read_trajectory(path, model_joint_names(engine.model))
    assert trajectory.joint_names == ("joint_3", "joint_1")
    assert trajectory.positions.tolist() == [[0.5, 0.1], [0.6, 0.2]]
    assert trajectory.targets is not None and trajectory.targets.tolist() == [[0.6, 0.2], [0.7, 0.3]]
    plain = read_trajectory(write_csv(["timestamp,joint_1", "0,0.1"]))
    assert plain.targets is None


def test_target_columns_of_some_joints(engine, write_csv) -> None:
    partial = read_trajectory(write_csv(["timestamp,joint_1,joint_2,joint_1.target", "0,0.5,0,0.25"]))
    assert partial.targets[0, 0] == 0.25 and np.isnan(partial.targets[0, 1])  # joint_2 had no command
    with pytest.raises(TrajectoryError, match=r"target column\(s\) joint_7.target without the joint's own column"):
        read_trajectory(write_csv(["timestamp,joint_1,joint_1.target,joint_7.target", "0,0,0,0"]))
    trajectory = read_trajectory(write_csv(["timestamp,joint_1,joint_1.target", "0,0,0", "0.1,0,nan"]))
    with pytest.raises(TrajectoryError, match=r"motion.csv:3: NaN or infinite value"):
        trajectory.require_playable()


def test_missing_timestamp_column(engine, write_csv) -> None:
    path = write_csv(["# recorded on the bench", "time,joint_1,joint_2", "0,0,0"])
    with pytest.raises(TrajectoryError) as error:
        read_trajectory(path, model_joint_names(engine.model))
    assert f"{path}:2: the header has no 'timestamp' column ('time' is close; rename it)" in str(error.value)


def test_unknown_joint_lists_the_models_joints(engine, write_csv) -> None:
    path = write_csv(["timestamp,joint_1,joint_7,elbow", "0,0,0,0"])
    with pytest.raises(TrajectoryError) as error:
        read_trajectory(path, model_joint_names(engine.model))
    message = str(error.value)
    assert message.startswith(f"{path}:1: columns 'joint_7' (did you mean: joint_6, joint_5?)")
    assert "'elbow'" in message and "its joints: joint_1, joint_2, joint_3, joint_4, joint_5, joint_6" in message


@pytest.mark.parametrize("content", ["", "# only a comment\n\n"])
def test_empty_file(engine, tmp_path: Path, content: str) -> None:
    path = tmp_path / "empty.csv"
    path.write_text(content)
    with pytest.raises(TrajectoryError, match=r"empty.csv:\d+: no header line: the file is empty or has only comments"):
        read_trajectory(path)


def test_header_without_rows_and_ragged_and_text_values(write_csv) -> None:
    with pytest.raises(TrajectoryError, match=r"motion.csv:1: the header is not followed by any data row"):
        read_trajectory(write_csv([HEADER]))
    with pytest.raises(TrajectoryError, match=r"motion.csv:3: row has 6 values, the header \(line 1\) has 7 columns"):
        read_trajectory(write_csv([HEADER, f"0,{HOME}", "0.1,0,0,0,0,0"]))
    with pytest.raises(TrajectoryError, match=r"motion.csv:2: column 'joint_4' has 'up', which is not a number"):
        read_trajectory(write_csv([HEADER, "0,0,0,0,up,0,0"]))


def test_nan_reversed_duplicate_and_out_of_range_rows_are_reported_with_lines(engine, write_csv) -> None:
    path = write_csv(
        [
            HEADER,
            f"0.00,{HOME}",
            "0.01,0.0,nan,0.35,1.0,0.0,0.4",  # line 3: NaN
            f"0.02,{HOME}",
            f"0.015,{HOME}",  # line 5: goes back
            f"0.02,{HOME}",  # line 6: repeats
            "0.03,2.5,-0.35,0.35,1.0,0.0,0.4",  # line 7: joint_1 beyond 1.92, and fast
            f"0.04,{HOME}",
            f"1.00,{HOME}",
        ]
    )
    report, usable = check(engine, path)
    by_kind = {issue.kind: issue for issue in report.issues}
    assert by_kind["non_finite"].first_line == 3 and "joint_2=nan; row skipped" in by_kind["non_finite"].message
    timestamps = [issue for issue in report.issues if issue.kind == "timestamp"]
    assert [(issue.first_line, issue.message.split(": ", 1)[1]) for issue in timestamps] == [
        (5, "timestamp 0.015 is before the previous one, 0.02 (line 4); row skipped"),
        (6, "timestamp 0.02 repeats the previous one, 0.02 (line 4); row skipped"),
    ]
    limit = by_kind["joint_limit"]
    assert (limit.subject, limit.first_line, limit.worst_value) == ("joint_1", 7, 2.5)
    assert "motion.csv:7: joint_1 outside its range [-1.92, 1.92]: 2.5 at line 7" == limit.message
    fast = [issue for issue in report.issues if issue.kind == "velocity"]
    assert {issue.subject for issue in fast} == {"joint_1"}
    assert fast[0].first_line == 7 and fast[0].last_line == 8 and fast[0].worst_value == pytest.approx(250.0)
    assert usable.tolist() == [True, False, True, False, False, True, True, True]
    assert report.replayed_rows == 5 and not report.ok


def test_penetration_of_the_table_and_of_the_arm_itself(engine, write_csv) -> None:
    folded = "0.0,0.0,1.69,1.658,0.0,0.4"  # forearm folded back onto the shoulder
    into_table = "0.0,1.7,0.35,1.0,0.0,0.4"  # shoulder pitched down through the table top
    path = write_csv([HEADER, f"0,{HOME}", f"1,{folded}", f"2,{HOME}", f"3,{into_table}", f"4,{into_table}"])
    report, _ = check(engine, path)
    self_hits = [issue for issue in report.issues if issue.kind == "self_penetration"]
    table_hits = [issue for issue in report.issues if issue.kind == "world_penetration"]
    assert self_hits and all(issue.first_line == issue.last_line == 3 for issue in self_hits)
    assert any("shoulder" in issue.subject and "forearm" in issue.subject for issue in self_hits)
    assert table_hits and all((issue.first_line, issue.last_line) == (5, 6) for issue in table_hits)
    assert all("table_top" in issue.subject and issue.worst_value > 0.005 for issue in table_hits)
    assert "mm deep (threshold 5 mm)" in table_hits[0].message


def test_each_problem_has_the_replay_time_of_its_first_line(engine, write_csv) -> None:
    beyond = "2.0," + HOME.split(",", 1)[1]  # joint_1 at 2 rad, beyond its range [-1.92, 1.92]
    lines = ["# recorded", HEADER, f"0,{HOME}", f"0.5,{HOME}", "0.7,0,nan,0,0,0,0", f"1.0,{beyond}", f"0.9,{HOME}"]
    path = write_csv([*lines, f"1.5,{HOME}"])  # file lines 3 to 8
    trajectory = read_trajectory(path, model_joint_names(engine.model))
    report, usable = validate(trajectory, engine.model, engine.data.qpos.copy())
    # a skipped row (NaN, timestamp going back) is passed over at the time of the last replayed row before it
    found = [(issue.kind, issue.first_line, issue.time) for issue in report.issues]
    assert found == [("non_finite", 5, 0.5), ("joint_limit", 6, 1.0), ("timestamp", 7, 1.0)], report.summary()
    assert [issue["time"] for issue in report.to_json()["issues"]] == [0.5, 1.0, 1.0]
    # a line before every row (the header) is at the first replayed row, one after them all at the last
    assert line_times(trajectory, usable, [2, 3, 4, 8, 9]).tolist() == [0.0, 0.0, 0.5, 1.5, 1.5]
    first_skipped = usable.copy()
    first_skipped[0] = False
    assert line_times(trajectory, first_skipped, [2, 3]).tolist() == [0.5, 0.5]
    assert np.isnan(line_times(trajectory, np.zeros_like(usable), [3])).all()


def test_cli_reports_and_replays_unless_strict(run_joshua, write_csv, tmp_path: Path) -> None:
    rows = example_rows(0.5)
    rows[10] = rows[10].split(",")[0] + ",0.0,nan,0.35,1.0,0.0,0.4"  # line 12 of the file
    path = write_csv([HEADER, *rows])
    args = ("--preset", "sim_passive", "--set", f"simulation.trajectory_path={path}", *SMALL)
    relaxed = run_joshua(*args)
    assert relaxed.returncode == 0, relaxed.stderr
    assert f"{path.name}:12: joint_2=nan; row skipped" in relaxed.stdout
    report = json.loads((tmp_path / "joshua_output" / "passive_report.json").read_text())
    assert report["ok"] is False and report["rows"] == 251 and report["replayed_rows"] == 250
    assert report["issues"][0]["kind"] == "non_finite" and report["issues"][0]["first_line"] == 12
    assert (tmp_path / "joshua_output" / "passive_replay.mp4").is_file()

    (tmp_path / "joshua_output" / "passive_replay.mp4").unlink()
    strict = run_joshua(*args, "--strict")
    assert strict.returncode == 2
    assert "not replayed because simulation.replay.strict is set (--strict)" in strict.stderr
    assert "Traceback" not in strict.stderr
    assert not (tmp_path / "joshua_output" / "passive_replay.mp4").exists()


@pytest.mark.parametrize(
    ("lines", "expected"),
    [
        (["joint_1,joint_2", "0,0"], ":1: the header has no 'timestamp' column"),
        (["timestamp,joint_9", "0,0"], ":1: column 'joint_9' (did you mean: joint_6, joint_5?)"),
        ([], ":1: no header line"),
        ([HEADER, f"1e300,{HOME}"], ":2: column 'timestamp' has 1e+300, beyond ±1e+09"),
        ([HEADER, f"0,{HOME}", "0.1,1e308,-1e308,0,0,0,0"], ":3: column 'joint_1' has 1e+308, beyond ±1e+09"),
    ],
)
def test_cli_unreadable_trajectory_is_one_line_exit_2(run_joshua, write_csv, lines, expected: str) -> None:
    path = write_csv(lines)
    result = run_joshua("--preset", "sim_passive", "--set", f"simulation.trajectory_path={path}")
    assert result.returncode == 2
    assert result.stderr.startswith("joshua: error: ") and expected in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def _strict_json(text: str) -> object:
    """Parse `text` as JSON proper: NaN and Infinity (which Python's json would accept) fail the test."""

    def refuse(constant: str) -> None:
        raise AssertionError(f"not JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


def test_huge_values_are_one_line_errors_with_their_line(write_csv) -> None:
    with pytest.raises(TrajectoryError, match=r"motion.csv:3: column 'timestamp' has 1e\+300, beyond"):
        read_trajectory(write_csv([HEADER, f"0,{HOME}", f"1e300,{HOME}"]))
    with pytest.raises(TrajectoryError, match=r"motion.csv:2: column 'joint_6' has -1e\+308, beyond"):
        read_trajectory(write_csv([HEADER, "0,0,0,0,0,0,-1e308"]))


def test_report_of_non_finite_rows_is_valid_json(engine, write_csv, tmp_path: Path) -> None:
    path = write_csv([HEADER, f"0,{HOME}", "inf,0,0,0,0,0,0", "0.1,0,nan,0,0,0,-inf", "1e-300,0,0,0,0,0,0"])
    report, usable = check(engine, path)
    assert usable.tolist() == [True, False, False, True]
    report.write(tmp_path / "report.json")
    document = _strict_json((tmp_path / "report.json").read_text())
    non_finite = [issue for issue in document["issues"] if issue["kind"] == "non_finite"]
    assert [issue["first_line"] for issue in non_finite] == [3, 4]
    assert all(issue["worst_value"] is None for issue in non_finite)
    assert "timestamp=inf" in non_finite[0]["message"] and "joint_6=-inf" in non_finite[1]["message"]


def test_target_columns_round_trip_exactly(tmp_path: Path) -> None:
    import numpy as np

    from joshua_core.plugins import PluginHost
    from joshua_core.trajectory import Trajectory, write_trajectory
    from joshua_core.trajectory_sources import load_trajectory

    times = np.array([0.0, 0.1, 0.2])
    positions = np.array([[0.1, 1 / 3], [0.2, 0.4], [0.3, 0.5]])
    targets = np.array([[0.15, np.nan], [0.25, np.nan], [1e-17, np.nan]])  # joint_2 has no target column
    written = Trajectory(tmp_path / "t.csv", ("joint_1", "joint_2"), times, positions, np.arange(3), targets)
    write_trajectory(written.path, written, comment="two joints\none target")
    text = written.path.read_text()
    assert text.startswith("# two joints\n# one target\ntimestamp,joint_1,joint_2,joint_1.target\n")
    host = PluginHost([])
    read = load_trajectory(written.path, {"joint_1": (-1.0, 1.0), "joint_2": (-1.0, 1.0)}, plugins=host)
    assert read.joint_names == ("joint_1", "joint_2")
    assert np.array_equal(read.positions, positions) and np.array_equal(read.targets, targets, equal_nan=True)
    with pytest.raises(TrajectoryError, match="holds one episode; episode 1 does not exist"):
        load_trajectory(written.path, {"joint_1": (-1.0, 1.0), "joint_2": (-1.0, 1.0)}, episode=1, plugins=host)


def test_a_target_column_needs_its_joint_column(tmp_path: Path) -> None:
    path = tmp_path / "orphan.csv"
    path.write_text("timestamp,joint_1,joint_2.target\n0.0,0.1,0.2\n")
    with pytest.raises(TrajectoryError, match=r"orphan.csv:1: target column\(s\) joint_2.target without the joint's"):
        read_trajectory(path)


def test_a_folder_without_a_reader_says_what_to_install(tmp_path: Path) -> None:
    from joshua_core import builtin_plugin
    from joshua_core.plugins import PluginHost, PluginInfo
    from joshua_core.trajectory_sources import load_trajectory

    host = PluginHost([(PluginInfo("core", "joshua-core", "0", "core"), builtin_plugin)])
    with pytest.raises(TrajectoryError, match="no installed trajectory reader takes it .*pip install joshua-lerobot"):
        load_trajectory(tmp_path, {"joint_1": (-1.0, 1.0)}, plugins=host)
