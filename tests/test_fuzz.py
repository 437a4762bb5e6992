"""Property-based fuzzing of what users type and feed in: config text, `--set` strings and trajectory CSV bytes.

Whatever the input, `joshua` exits 0 or 2, a failure is one `joshua: error:` line (never a traceback: the
CLI runs in-process here, so any other exception fails the test with the input that caused it), and
nothing is written outside the run's output folder. Examples are derandomized, so CI sees the same ones
on every run.
"""

from __future__ import annotations

import contextlib
import io
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from google.protobuf.descriptor import Descriptor, FieldDescriptor
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from joshua_core.cli import main
from joshua_core.config_pb2 import JoshuaConfig

FUZZ = settings(
    max_examples=60, derandomize=True, database=None, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
OUTPUT = "out"
# Plugin option fields (protobuf extensions, so not in JoshuaConfig's descriptor) that take numbers or lists.
PLUGIN_FIELDS = (
    "simulation.offscreen.fps",
    "simulation.offscreen.camera",
    "simulation.replay.speed",
    "simulation.replay.velocity_limit",
    "simulation.viewer.fps",
    "simulation.viewer.display",
    "simulation.mirror.rate_hz",
    "training.hidden_sizes[1]",
    "training.hidden_sizes[0]",
    "training.sb3.algorithm",
)
JOINTS = [f"joint_{i}" for i in range(1, 7)]
PRESETS = ("sim_passive", "sim_offscreen", "sim_mirror", "so_arm100_reach_sb3", "ant_train_mjx", "nope")


def field_paths(descriptor: Descriptor, prefix: str = "") -> Iterator[tuple[str, FieldDescriptor]]:
    """Every dotted scalar field path of a config message, nested messages included, with its field."""
    for field in descriptor.fields:
        path = f"{prefix}{field.name}"
        if field.type == FieldDescriptor.TYPE_MESSAGE and not field.message_type.GetOptions().map_entry:
            yield from field_paths(field.message_type, f"{path}.")
        elif field.type != FieldDescriptor.TYPE_MESSAGE:
            yield path, field


NUMBERS = st.one_of(
    st.integers(min_value=-(2**70), max_value=2**70),
    st.integers(min_value=-3, max_value=3000),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=-10, max_value=1e4),
    st.sampled_from(["nan", "-inf", "1e309", "1e300", "-0", "0x10", "1_000"]),
).map(str)
WORDS = st.one_of(
    st.sampled_from(["PASSIVE", "OFFSCREEN", "HEADLESS", "TRAINING", "SB3", "99", "true", "so_arm100/scene.xml", ""]),
    st.text(alphabet=st.characters(codec="utf-8", exclude_categories=["Cs"]), max_size=12),
)
QUOTED = WORDS.map(lambda word: '"' + word.replace("\\", "\\\\").replace('"', '\\"') + '"')
ANY_VALUE = st.one_of(NUMBERS, QUOTED, WORDS)


def value_of(field: FieldDescriptor | None) -> st.SearchStrategy[str]:
    """Mostly values of the field's own type (so that parsing passes and the checks behind it run), else anything."""
    if field is None:
        own = NUMBERS
    elif field.type == FieldDescriptor.TYPE_ENUM:
        own = st.sampled_from([value.name for value in field.enum_type.values] + ["99", "NOPE"])
    elif field.type == FieldDescriptor.TYPE_STRING:
        own = QUOTED
    elif field.type == FieldDescriptor.TYPE_BOOL:
        own = st.sampled_from(["true", "false"])
    else:
        own = NUMBERS
    return st.one_of(own, own, own, ANY_VALUE)


FIELDS: dict[str, FieldDescriptor | None] = {
    **dict(field_paths(JoshuaConfig.DESCRIPTOR)),
    **{path: None for path in PLUGIN_FIELDS},
}
FIELD_VALUES = st.sampled_from(sorted(FIELDS)).flatmap(lambda path: st.tuples(st.just(path), value_of(FIELDS[path])))


@contextlib.contextmanager
def workdir() -> Iterator[Path]:
    """A fresh working directory for one example (hypothesis runs many examples in one test call)."""
    previous = Path.cwd()
    with tempfile.TemporaryDirectory() as folder:
        os.chdir(folder)
        try:
            yield Path(folder)
        finally:
            os.chdir(previous)


def run_cli(*argv: str) -> tuple[int, str]:
    """`joshua ARGV` in-process in the current directory: (exit status, stderr)."""
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        try:
            status = main(list(argv))
        except SystemExit as exit_:  # argparse's usage errors
            status = exit_.code if isinstance(exit_.code, int) else 2
    return status, stderr.getvalue()


def assert_clean_exit(status: int, stderr: str) -> None:
    assert status in (0, 2), (status, stderr)
    assert "Traceback" not in stderr, stderr
    if status == 2:
        errors = [line for line in stderr.splitlines() if line.startswith("joshua: error:") or "error:" in line]
        assert len(errors) == 1, stderr


def written_outside(folder: Path, inputs: set[str]) -> list[str]:
    """Files in the working directory other than the inputs and the output folder's."""
    return sorted(
        str(path.relative_to(folder))
        for path in folder.rglob("*")
        if path.is_file() and path.name not in inputs and path.relative_to(folder).parts[0] != OUTPUT
    )


def as_text(fields: list[tuple[str, str]]) -> str:
    """Dotted fields and values as text format, nested: `a.b.c` = V -> `a { b { c: V } }` (an index `c[1]` becomes
    the field `c`); fields that share a message share its block."""
    tree: dict[str, Any] = {}
    for path, value in fields:
        *messages, leaf = path.split(".")
        node = tree
        for name in messages:
            node = node.setdefault(name, {})
        node[leaf.split("[")[0]] = value

    def render(node: dict[str, Any]) -> str:
        return " ".join(
            f"{key} {{ {render(item)} }}" if isinstance(item, dict) else f"{key}: {item}" for key, item in node.items()
        )

    return render(tree)


def rarely(draw: st.DrawFn, one_in: int) -> bool:
    """True about once in `one_in` draws (hypothesis favours small integers, so the rare case is the largest)."""
    return draw(st.integers(0, one_in - 1)) == one_in - 1


@st.composite
def config_texts(draw: st.DrawFn) -> bytes:
    """Config files: mostly a shipped preset extended with fields of arbitrary values, perhaps with a splice
    of garbage; sometimes arbitrary bytes."""
    if rarely(draw, 10):
        return draw(st.binary(max_size=200))
    lines = [f'extends: "{draw(st.sampled_from(PRESETS))}"'] if not rarely(draw, 4) else []
    lines.append(as_text(draw(st.lists(FIELD_VALUES, max_size=4))))
    text = "\n".join(lines)
    if rarely(draw, 3):
        at = draw(st.integers(0, len(text)))
        text = text[:at] + draw(st.text(max_size=4)) + text[at:]
    return text.encode("utf-8", "surrogatepass")


@given(config_texts())
@example(b'extends: "sim_passive"\ntraining { task_config { events { mode: 2147483648 } } }')  # an enum's 2**31
@FUZZ
def test_any_config_file_is_a_clean_exit(text: bytes) -> None:
    with workdir() as folder:
        (folder / "fuzz.pbtxt").write_bytes(text)
        status, stderr = run_cli("--config", "fuzz.pbtxt", "--print-config")
        assert_clean_exit(status, stderr)
        assert written_outside(folder, {"fuzz.pbtxt"}) == []


@given(st.lists(st.tuples(FIELD_VALUES, st.sampled_from(["=", "=", "=", "==", ":", ""])), max_size=3))
@FUZZ
def test_any_set_strings_are_a_clean_exit(overrides: list[tuple[tuple[str, str], str]]) -> None:
    arguments = [argument for (path, value), sep in overrides for argument in ("--set", f"{path}{sep}{value}")]
    with workdir() as folder:
        status, stderr = run_cli(*arguments, "--print-config")
        assert_clean_exit(status, stderr)
        assert written_outside(folder, set()) == []


CELLS = st.sampled_from(["nan", "inf", "-1e308", "1e300", "", "x", '"1"', "1e-320", "4.5"])


@st.composite
def trajectory_csvs(draw: st.DrawFn) -> bytes:
    """Trajectory CSVs near the real format (timestamps within a few seconds, so a valid one replays
    quickly), now and then with a wrong header, cell or row length; sometimes arbitrary bytes."""
    if rarely(draw, 8):
        return draw(st.binary(max_size=300))
    header = ["timestamp", *JOINTS[: draw(st.integers(1, 6))]]
    if rarely(draw, 6):
        header[draw(st.integers(0, len(header) - 1))] = draw(st.text(max_size=6))
    rows = [",".join(header)]
    time = 0.0
    for _ in range(0 if rarely(draw, 10) else draw(st.integers(2, 6))):
        time += draw(st.floats(min_value=-0.1 if rarely(draw, 6) else 0.01, max_value=0.5))
        cells = [f"{time:.3f}", *(f"{draw(st.floats(-3, 3)):.3f}" for _ in header[1:])]
        if rarely(draw, 12):
            cells[draw(st.integers(0, len(cells) - 1))] = draw(CELLS)
        if rarely(draw, 8):
            cells = cells[:-1] if draw(st.booleans()) else [*cells, "0"]
        rows.append(",".join(cells))
    return "\n".join(rows).encode("utf-8", "surrogatepass")


@pytest.mark.slow
@given(trajectory_csvs())
@settings(FUZZ, max_examples=25)
def test_any_trajectory_csv_is_a_clean_exit(csv: bytes) -> None:
    """The embedded default job (validate, then record the replay) on a fuzzed CSV, rendered tiny."""
    with workdir() as folder:
        (folder / "fuzz.csv").write_bytes(csv)
        status, stderr = run_cli(
            *("--set", "simulation.trajectory_path=fuzz.csv", "--set", f"simulation.output_dir={OUTPUT}"),
            *("--set", "simulation.render_width=32", "--set", "simulation.render_height=24"),
        )
        assert_clean_exit(status, stderr)
        assert written_outside(folder, {"fuzz.csv"}) == []
