"""The guides, presets and comments keep to tools/check_docs.py, and the check finds each kind of breach."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

REPO_ROOT = Path(__file__).resolve().parents[1]


def check_docs() -> ModuleType:
    spec = importlib.util.spec_from_file_location("check_docs", REPO_ROOT / "tools" / "check_docs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


CLEAN = {
    "README.md": "# Project\n\nSee [the guide](docs/guide.md#training) and [presets](presets/).\n",
    "docs/guide.md": (
        "# Guide\n\n## Training\n\nTrain with several seeds (`bench/seeds.py --seeds 0 1 2`).\n"
        "Then [run it](#step-1-the-run-command).\n\n"
        "## Step 1: the `run` command\n\n| field | meaning |\n|---|---|\n| `seed` | the random seed |\n\n"
        "```bash\n# a comment in a code block is no heading\n```\n"
    ),
    "presets/run.pbtxt": "# Trains the arm; 0.9 success in about 80 s (docs/guide.md#training)\ntraining { seed: 3 }\n",
    "pkg/module.py": (
        '"""A module (docs/guide.md#step-1-the-run-command)."""\n\n'
        "# the step runs no slower on a GPU\nVALUE = 'H100 in a string is code, not a comment'\n"
    ),
    "bench/measure.py": "# 2026-01-02 on one H100, written to bench/RESULTS.md: ran 5 % faster than before\n",
    "bench/RESULTS.md": "## 2026-01-02 · seeds 1 2 3\n\n| seed | return |\n|---|---|\n| 1 | 5 |\n",
    ".venv/lib/site.py": "# 2026-01-02 H100\n",
}


def tree(root: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    return root


def test_the_repository_keeps_the_rules() -> None:
    assert check_docs().findings() == []


def test_a_clean_tree_has_no_findings(tmp_path: Path) -> None:
    assert check_docs().findings(tree(tmp_path, CLEAN)) == []


def test_each_breach_is_one_line_naming_its_place(tmp_path: Path) -> None:
    broken = {
        **CLEAN,
        "docs/long.md": "# Long\n" + "line\n" * 500,
        "docs/record.md": (
            "# Record\n\nOn 2026-11-28 five seeds of seven reached it; seed 605 did not.\n\n"
            "| seed | return |\n|---|---|\n| 1 | 5 |\n\nSee [gone](guide.md#nowhere) and [lost](missing.md).\n"
        ),
        "presets/run.pbtxt": "# 13 of 13 seeds reached 0.8\ntraining { seed: 3 }\n",
        "pkg/module.py": (
            '"""Measured 2026-11-28."""\n\n# on an H200 this ran 3 ms faster than before (bench/RESULTS.md)\n'
            "X = 1  # see docs/guide.md#nowhere\n"
        ),
    }
    found = check_docs().findings(tree(tmp_path, broken))
    assert found == [
        "docs/long.md: 501 lines, more than 500: split it by topic",
        "docs/record.md:3: a date (2026-11-28): dated entries belong in bench/RESULTS.md",
        "docs/record.md:3: seeds counted or named ('five seeds'): the record of runs belongs in bench/RESULTS.md",
        "docs/record.md:5: a seed table: tables of runs belong in bench/RESULTS.md",
        "docs/record.md:9: link to guide.md#nowhere: no heading #nowhere in guide.md",
        "docs/record.md:9: link to missing.md: no such file",
        "presets/run.pbtxt:1: seeds counted or named ('13 seeds'): the record of runs belongs in bench/RESULTS.md",
        "pkg/module.py:1: a comment cites '2026-11-28': state the invariant or the reason; measurements, hardware "
        "and history belong in bench/RESULTS.md",
        "pkg/module.py:3: a comment cites 'H200': state the invariant or the reason; measurements, hardware "
        "and history belong in bench/RESULTS.md",
        "pkg/module.py:4: docs/guide.md#nowhere: no such heading",
    ]
