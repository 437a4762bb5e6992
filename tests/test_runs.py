"""Run folders: unique names under concurrent creators, the lock between processes, atomic checkpoints that
never show half-written, and listing, newest and resume. Real processes, synchronised with events."""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
from multiprocessing.synchronize import Barrier, Event
from pathlib import Path
from typing import Any

import pytest

from joshua_core import runs
from joshua_core.errors import ConfigError, UsageError
from joshua_core.runs import (
    CONFIG_FILE,
    RunInUseError,
    create_run,
    list_runs,
    newest_run,
    open_run,
    resolve_checkpoint,
    resume_run,
)

SPAWN = multiprocessing.get_context("spawn")
WAIT = 60  # seconds an event may take before the test fails (a hung process), never a pause


def _create_and_hold(root: Path, name: str | None, start: Barrier, results: Any, release: Event) -> None:
    """In a child: create a run (the default name frozen to one value, so that creators collide), report it,
    and hold its lock until released."""
    runs.default_run_name = lambda stem, now=None: f"{stem}_frozen"
    start.wait(WAIT)
    try:
        run = create_run(root, name, stem="walk", options="training.x")
    except UsageError as error:
        results.put(("error", type(error).__name__, str(error), os.getpid()))
        return
    results.put(("run", run.name, "", os.getpid()))
    release.wait(WAIT)
    run.close()


def _start_creators(root: Path, name: str | None, count: int) -> tuple[list[Any], list[tuple[str, str, str, int]], Any]:
    start, results, release = SPAWN.Barrier(count), SPAWN.Queue(), SPAWN.Event()
    processes = [
        SPAWN.Process(target=_create_and_hold, args=(root, name, start, results, release)) for _ in range(count)
    ]
    for process in processes:
        process.start()
    reports = [results.get(timeout=WAIT) for _ in processes]
    return processes, reports, release


def _finish(processes: list[Any], release: Any) -> None:
    release.set()
    for process in processes:
        process.join(WAIT)
        assert process.exitcode == 0


def test_concurrent_creators_with_the_default_name_get_different_folders(tmp_path: Path) -> None:
    processes, reports, release = _start_creators(tmp_path, None, 4)
    try:
        names = sorted(name for kind, name, _, _ in reports if kind == "run")
        assert names == ["walk_frozen", "walk_frozen_2", "walk_frozen_3", "walk_frozen_4"], reports
        holders = {(tmp_path / name / runs.LOCK_FILE).read_text().strip() for name in names}
        assert holders == {str(pid) for _, _, _, pid in reports}  # each folder's lock names its own process
    finally:
        _finish(processes, release)
    assert sorted(path.name for path in tmp_path.iterdir()) == names  # no hidden folder left behind


def test_the_same_name_at_once_one_wins_and_the_other_learns_who_holds_it(tmp_path: Path) -> None:
    processes, reports, release = _start_creators(tmp_path, "mine", 2)
    try:
        (winner,) = [report for report in reports if report[0] == "run"]
        (loser,) = [report for report in reports if report[0] == "error"]
        assert loser[1] == "RunInUseError" and f"by process {winner[3]}" in loser[2] and "\n" not in loser[2]
        assert sorted(path.name for path in tmp_path.iterdir()) == ["mine"]
        assert [path.name for path in (tmp_path / "mine").iterdir()] == [runs.LOCK_FILE]
        with pytest.raises(RunInUseError, match=f"process {winner[3]}"):
            open_run(tmp_path, "mine")
    finally:
        _finish(processes, release)
    with open_run(tmp_path, "mine") as run:  # free once its holder ended
        assert (run.path / runs.LOCK_FILE).read_text().strip() == str(os.getpid())
        (run.path / CONFIG_FILE).write_text("{}")  # a run that wrote something keeps its name
    with pytest.raises(ConfigError, match=r"run folder .*mine exists; continue it with --set training.x.resume=true"):
        create_run(tmp_path, "mine", stem="walk", options="training.x")


def test_a_failed_checkpoint_write_leaves_no_folder(tmp_path: Path) -> None:
    with create_run(tmp_path, "r", stem="walk", options="training.x") as run:
        with pytest.raises(RuntimeError), run.publish(5) as folder:
            (folder / "params.msgpack").write_bytes(b"half")
            raise RuntimeError("the writer failed")
        assert run.checkpoints() == [] and sorted(path.name for path in tmp_path.iterdir()) == ["r"]
        with run.publish(5) as folder:
            (folder / "params.msgpack").write_bytes(b"whole")
            assert not run.checkpoint_path(5).exists()
        assert [path.name for path in run.checkpoints()] == ["r_step_5"]
        assert (tmp_path / "r_step_5" / "params.msgpack").read_bytes() == b"whole"


def test_a_new_run_that_fails_before_writing_anything_leaves_no_folder(tmp_path: Path) -> None:
    with pytest.raises(RuntimeError), create_run(tmp_path, "r", stem="walk", options="training.x"):
        raise RuntimeError("the environment could not be made")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(RuntimeError), create_run(tmp_path, "r", stem="walk", options="training.x") as run:
        (run.path / CONFIG_FILE).write_text("{}")
        raise RuntimeError("failed after writing")
    assert [path.name for path in tmp_path.iterdir()] == ["r"]  # what it wrote stays


def _publish_and_hang(root: Path, writing: Event) -> None:
    with open_run(root, "r") as run, run.publish(3) as folder:
        (folder / "params.msgpack").write_bytes(b"half")
        writing.set()
        signal.pause()  # killed here, mid-checkpoint


def test_a_writer_killed_mid_checkpoint_leaves_nothing_visible_and_the_next_one_cleans_up(tmp_path: Path) -> None:
    create_run(tmp_path, "r", stem="walk", options="training.x").close()
    writing = SPAWN.Event()
    writer = SPAWN.Process(target=_publish_and_hang, args=(tmp_path, writing))
    writer.start()
    assert writing.wait(WAIT)
    writer.kill()
    writer.join(WAIT)
    names = sorted(path.name for path in tmp_path.iterdir())
    assert names[-1] == "r" and len(names) == 2 and names[0].startswith(".r_step_3."), names
    with open_run(tmp_path, "r") as run:  # the lock died with its holder
        assert run.checkpoints() == []
        with run.publish(4) as folder:
            (folder / "params.msgpack").write_bytes(b"whole")
    assert sorted(path.name for path in tmp_path.iterdir()) == ["r", "r_step_4"]


def _run_with_config(root: Path, name: str, trainer: str, mtime: float, steps: tuple[int, ...] = ()) -> Path:
    with create_run(root, name, stem="walk", options="training.x") as run:
        (run.path / CONFIG_FILE).write_text(json.dumps({"trainer": trainer}))
        os.utime(run.path / CONFIG_FILE, (mtime, mtime))
        for step in steps:
            with run.publish(step) as folder:
                (folder / CONFIG_FILE).write_text(json.dumps({"trainer": trainer}))
        return run.path


def test_listing_newest_and_resume(tmp_path: Path) -> None:
    old = _run_with_config(tmp_path, "old", "ppo", 1_000, steps=(0, 9, 10))
    other = _run_with_config(tmp_path, "other", "sb3", 3_000)
    new = _run_with_config(tmp_path, "new", "ppo", 2_000)
    being_written = tmp_path / ".old_step_11.x1y2.tmp"  # a checkpoint being published
    being_written.mkdir()
    (being_written / CONFIG_FILE).write_text(json.dumps({"trainer": "ppo"}))
    assert list_runs(tmp_path) == [old, new, other]  # checkpoint folders are not runs
    assert list_runs(tmp_path, "ppo") == [old, new] and newest_run(tmp_path, "ppo") == new
    assert newest_run(tmp_path / "missing") is None
    assert resolve_checkpoint(old) == tmp_path / "old_step_10"  # by step, not by name
    (tmp_path / "old_step_50").mkdir()  # a stray empty folder: no checkpoint, skipped
    (tmp_path / "old_step_60").mkdir()  # a stray folder with a config.json but never published: skipped too
    (tmp_path / "old_step_60" / CONFIG_FILE).write_text(json.dumps({"trainer": "ppo"}))
    assert resolve_checkpoint(old) == tmp_path / "old_step_10"
    assert [path.name for path in runs.run_checkpoints(tmp_path, "old")] == ["old_step_0", "old_step_9", "old_step_10"]
    assert resolve_checkpoint(tmp_path / "old_step_9") == tmp_path / "old_step_9"
    with pytest.raises(UsageError, match="has no checkpoint yet"):
        resolve_checkpoint(new)

    run, saved = resume_run(tmp_path, None, trainer="ppo", options="training.x")
    with run:
        assert run.path == new and saved == {"trainer": "ppo"}
        with pytest.raises(RunInUseError, match=f"process {os.getpid()}"):
            open_run(tmp_path, "new")  # a second holder, even in this process, is refused
    with pytest.raises(ConfigError, match="trained by 'sb3', not 'ppo'"):
        resume_run(tmp_path, "other", trainer="ppo", options="training.x")
    with pytest.raises(ConfigError, match=r"training.x.resume: there is no run 'gone'"):
        resume_run(tmp_path, "gone", trainer="ppo", options="training.x")
    with pytest.raises(ConfigError, match="there is no td3 run"):
        resume_run(tmp_path, None, trainer="td3", options="training.x")


def test_a_file_given_as_run_folder_is_named_a_file(tmp_path: Path) -> None:
    path = tmp_path / "model.zip"
    path.write_bytes(b"not a folder")
    with pytest.raises(UsageError, match=f"^'{path}' is a file, not a run folder"):
        runs.read_run_config(path)


def test_a_command_line_run_name_in_use_says_choose_another(tmp_path: Path) -> None:
    with create_run(tmp_path, "fit", stem="sysid", options="--run-name") as run:
        (run.path / "report.json").write_text("{}")
    with pytest.raises(ConfigError) as raised:
        create_run(tmp_path, "fit", stem="sysid", options="--run-name")
    assert str(raised.value) == f"run folder {tmp_path / 'fit'} exists; choose another --run-name"
    (tmp_path / "photos").mkdir()  # a folder no run made: refused as it is, no lock file added to it
    (tmp_path / "photos" / "beach.jpg").write_bytes(b"jpeg")
    with pytest.raises(ConfigError, match="photos exists; choose another --run-name"):
        create_run(tmp_path, "photos", stem="sysid", options="--run-name")
    assert [path.name for path in (tmp_path / "photos").iterdir()] == ["beach.jpg"]


def test_a_run_killed_before_writing_anything_leaves_its_name_usable(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Killed while starting, a run leaves its folder holding only the lock file with its pid (the lock itself goes
    with the process): resuming it says there is nothing to resume, and a new run of that name takes the folder
    over, in one line; a folder holding anything else is left as it is."""
    processes, reports, _ = _start_creators(tmp_path, "mine", 1)
    (kind, _, _, pid), (holder,) = reports[0], processes
    assert kind == "run"
    holder.kill()
    holder.join(WAIT)
    assert [path.name for path in (tmp_path / "mine").iterdir()] == [runs.LOCK_FILE]

    with pytest.raises(ConfigError) as nothing:
        resume_run(tmp_path, "mine", trainer="sb3", options="training.x")
    assert str(nothing.value) == (
        f"training.x.resume: run folder {tmp_path / 'mine'} holds nothing to resume (only the lock of process {pid}, "
        "which wrote nothing): start the run without resume"
    )
    capsys.readouterr()
    with create_run(tmp_path, "mine", stem="walk", options="training.x") as run:
        assert run.path == tmp_path / "mine"
        assert (run.path / runs.LOCK_FILE).read_text() == f"{os.getpid()}\n"
        with pytest.raises(RunInUseError):
            open_run(tmp_path, "mine")  # held by this run now
        (run.path / CONFIG_FILE).write_text("{}")
    assert capsys.readouterr().err == (
        f"joshua: warning: run folder {tmp_path / 'mine'} held only the lock of process {pid}, which ended before "
        "writing anything; this run starts afresh in it\n"
    )

    for name, files in {
        "notes": {runs.LOCK_FILE: f"{pid}\n", "notes.txt": "mine"},
        "odd": {runs.LOCK_FILE: "x"},
    }.items():
        for file, text in files.items():  # a folder holding more than a lock, and one whose lock names no process
            (tmp_path / name).mkdir(exist_ok=True)
            (tmp_path / name / file).write_text(text)
        with pytest.raises(ConfigError, match=f"run folder {tmp_path / name} exists"):
            create_run(tmp_path, name, stem="walk", options="training.x")
        assert sorted(path.name for path in (tmp_path / name).iterdir()) == sorted(files)  # left as it was
    assert (tmp_path / "notes" / "notes.txt").read_text() == "mine"
