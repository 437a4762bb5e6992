"""joshua_core.outputs: names that become paths are one plain component, writes stay inside their folder, only a
folder joshua wrote is ever replaced, and the user's cache folder follows XDG with one switch to leave it unused
(--no-cache, JOSHUA_NO_CACHE; what joshua-jax keeps there: its tests/test_compile_cache.py)."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from joshua_core.cli import build_parser
from joshua_core.errors import UsageError
from joshua_core.evaluation import EvalCommand
from joshua_core.outputs import (
    MARKER,
    NO_CACHE_ENV_VAR,
    apply_no_cache,
    cache_enabled,
    check_inside,
    check_name,
    check_replaceable,
    output_folder,
    user_cache_dir,
)
from joshua_core.runs import check_run_name, create_run, open_run


@pytest.mark.parametrize(
    ("name", "problem"),
    [
        ("", "is empty"),
        (".", "not a name of its own"),
        ("..", "not a name of its own"),
        ("a/b", "holds a '/'"),
        ("/../../tmp/x", "holds a '/'"),
        ("a\\b", "holds a '/' or '\\'"),
        ("a\0b", "holds a NUL byte"),
        ("x" * 256, "is 256 bytes long (at most 255)"),
        ("é" * 128, "is 256 bytes long"),  # bytes, not characters
    ],
)
def test_a_name_that_is_not_one_plain_component_is_refused(name: str, problem: str) -> None:
    with pytest.raises(UsageError, match="--name") as refused:
        check_name(name, "--name")
    assert problem in str(refused.value) and "\n" not in str(refused.value)


def test_plain_names_pass_and_run_names_may_not_end_like_a_checkpoint() -> None:
    assert check_name("x" * 255, "--name") == "x" * 255
    assert check_run_name("reach_2", "--run-name") == "reach_2"
    assert check_run_name("x_step_", "--run-name") == "x_step_"
    with pytest.raises(UsageError, match=r"'x_step_99999' ends in _step_<N>"):
        check_run_name("x_step_99999", "--run-name")


def test_a_path_that_leads_outside_its_folder_through_a_link_is_refused(tmp_path: Path) -> None:
    root, elsewhere = tmp_path / "root", tmp_path / "elsewhere"
    root.mkdir()
    elsewhere.mkdir()
    assert check_inside(root, root / "a" / "b", "file") == root / "a" / "b"
    (root / "link").symlink_to(elsewhere)
    with pytest.raises(UsageError, match="leads outside"):
        check_inside(root, root / "link" / "m.stl", "file")
    with pytest.raises(UsageError, match="leads outside"):
        check_inside(root, root / ".." / "elsewhere", "file")
    with pytest.raises(UsageError, match="leads outside"):  # a run folder that is a link out of the root
        open_run(root, "link")
    assert list(elsewhere.iterdir()) == []


def test_a_run_is_never_named_by_a_path(tmp_path: Path) -> None:
    for name in ("../x", "a/b", "x_step_3"):
        with pytest.raises(UsageError):
            create_run(tmp_path / "root", name, stem="walk", options="training.x")
    assert list((tmp_path / "root").iterdir()) == [] and sorted(p.name for p in tmp_path.iterdir()) == ["root"]


def test_only_a_marked_folder_is_replaced_and_only_with_overwrite(tmp_path: Path) -> None:
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    (tmp_path / "file").write_text("keep")
    (tmp_path / "link").symlink_to(tmp_path / "elsewhere")
    for overwrite in (False, True):
        for path, problem in (
            (mine, "was not written by joshua"),
            (tmp_path / "file", "is a file"),
            (tmp_path / "link", "symbolic link"),
            (Path("."), "names no folder of its own"),
            (tmp_path / "..", "names no folder of its own"),
        ):
            with pytest.raises(UsageError, match=problem):
                check_replaceable(path, overwrite=overwrite, option="--out")
    assert (mine / "notes.txt").read_text() == "keep" and (tmp_path / "file").read_text() == "keep"

    (tmp_path / "empty").mkdir()
    with output_folder(tmp_path / "empty", overwrite=False, option="--out") as folder:
        (folder / "data.txt").write_text("first")
    assert (tmp_path / "empty" / MARKER).is_file()
    with (
        pytest.raises(UsageError, match="exists; pass --overwrite"),
        output_folder(tmp_path / "empty", overwrite=False, option="--out"),
    ):
        pass
    with output_folder(tmp_path / "empty", overwrite=True, option="--out") as folder:
        (folder / "data.txt").write_text("second")
    assert (tmp_path / "empty" / "data.txt").read_text() == "second"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty", "file", "link", "mine"]  # no temporaries


def test_a_folder_put_there_while_writing_is_not_replaced(tmp_path: Path) -> None:
    target = tmp_path / "out"
    with pytest.raises(UsageError, match="was not written by joshua"):
        with output_folder(target, overwrite=True, option="--out") as folder:
            (folder / "data.txt").write_text("new")
            target.mkdir()
            (target / "theirs.txt").write_text("keep")
    assert [p.name for p in target.iterdir()] == ["theirs.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_an_out_folder_where_nothing_can_be_made_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    from joshua_core.cli import main
    from joshua_core.resources import models_dir

    example = str(models_dir() / "trajectories" / "so_arm100_example.csv")
    assert main(["lerobot-export", example, "--out", "/proc/nope"]) == 2  # /proc takes no new folder, even as root
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and error.startswith("joshua: error: /proc/") and "Traceback" not in error, error


def test_user_cache_dir_follows_xdg(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert user_cache_dir() == tmp_path / "joshua"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/cache")  # the XDG rule: a relative path is ignored
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert user_cache_dir() == tmp_path / "home" / ".cache" / "joshua"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert user_cache_dir() == tmp_path / "home" / ".cache" / "joshua"


@pytest.mark.parametrize("value, enabled", [("", True), ("0", True), ("false", True), ("1", False), ("yes", False)])
def test_the_no_cache_variable_values(monkeypatch: pytest.MonkeyPatch, value: str, enabled: bool) -> None:
    monkeypatch.setenv(NO_CACHE_ENV_VAR, value)
    assert cache_enabled() is enabled


def test_no_cache_on_the_command_line_sets_the_variable(monkeypatch: pytest.MonkeyPatch) -> None:
    eval_parser = argparse.ArgumentParser()
    EvalCommand().add_arguments(eval_parser)
    for args in (build_parser().parse_args(["--no-cache"]), eval_parser.parse_args(["some_run", "--no-cache"])):
        monkeypatch.delenv(NO_CACHE_ENV_VAR, raising=False)
        apply_no_cache(args)
        assert not cache_enabled()
    monkeypatch.delenv(NO_CACHE_ENV_VAR)
    apply_no_cache(build_parser().parse_args([]))
    assert cache_enabled()
