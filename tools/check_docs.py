"""Check that the guides stay guides and the lab record stays in bench/RESULTS.md (exit 1 on a finding, one line each).

    python tools/check_docs.py [ROOT]

- a guide (docs/**/*.md, README.md, plugins/*/README.md) has at most 500 lines: split it by topic, never to meet
  the number;
- a guide or a preset (presets/*.pbtxt) names no date (YYYY-MM-DD), holds no seed table (a markdown table with a
  `seed` column or row) and neither counts seeds ("five seeds of seven", "13 of 13 seeds") nor names them
  ("seed 605"): those are the record of single runs. A guide says what to do and why, once, and points into
  bench/RESULTS.md in one line where a figure backs it; a preset says what it is for and its one headline figure;
- a comment or docstring of the Python source names no GPU (`H100`, `H200`), no `RESULTS.md`, no date and no
  "faster than": it states the invariant or the reason, and the measurement behind it, if worth keeping, lives in
  bench/RESULTS.md;
- a relative link of a guide leads to a file that exists and, with `#anchor`, to one of its headings, and so does a
  `docs/NAME.md#anchor` written in the source, the presets or the schemas.

bench/ is left out of the comment rule: its scripts are the measurements, they write bench/RESULTS.md's entries and
name the machines they ran on, so their comments have to cite all three. bench/RESULTS.md itself is the lab record,
not a guide: it keeps every date, seed and machine.

`.ci/run` runs it after tools/check_architecture.py; tests/test_check_docs.py runs it on small trees.
"""

from __future__ import annotations

import ast
import io
import os
import re
import sys
import tokenize
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MAX_GUIDE_LINES = 500
# this check and its test name what it looks for (the test in its fixtures), so both are left out of the search
EXEMPT = {Path("tools", "check_docs.py"), Path("tests", "test_check_docs.py")}
# folders never searched: environments, caches, build outputs and run outputs
SKIPPED_DIRS = {"node_modules", "__pycache__", "build", "dist", "joshua_output", "checkpoints"}

DATE = re.compile(r"(?<![\w-])(?:19|20)\d\d-[01]\d-[0-3]\d(?![\w-])")
NUMBER = r"\d+|two|three|four|five|six|seven|eight|nine|ten|eleven|twelve|thirteen|fourteen|fifteen|twenty"
SEED_COUNT = re.compile(
    rf"\b(?:{NUMBER})\s+(?:(?:more|new|unseen|other|fresh|further|different)\s+)?seeds\b"  # "five seeds of seven"
    r"|(?<![-\w.])seeds?\s+\d+",  # "seed 605", "seeds 415 and 416"; not `--seeds 0 1`
    re.IGNORECASE,
)
SEED_CELL = re.compile(r"\s*\**seeds?\**\s*", re.IGNORECASE)
TABLE_RULE = re.compile(r"\s*\|?\s*:?-{3,}")
CODE_WORDS = re.compile(r"H100|H200|RESULTS\.md|faster than", re.IGNORECASE)
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
DOC_REFERENCE = re.compile(r"\b((?:docs|plugins)/[\w./-]+\.md)#([\w-]+)")


def searched(folder: Path, suffix: str) -> Iterator[Path]:
    """Files under folder whose names end in suffix, outside hidden folders (.venv, .cache, .git ...) and build or
    run outputs; the walk never enters those, so a large environment costs nothing."""
    for parent, dirs, files in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if not d.startswith(".") and d not in SKIPPED_DIRS)
        yield from (Path(parent, file) for file in sorted(files) if file.endswith(suffix))


def guides(root: Path) -> list[Path]:
    found = [*searched(root / "docs", ".md"), *sorted(root.glob("plugins/*/README.md"))]
    if (root / "README.md").is_file():
        found.insert(0, root / "README.md")
    return found


def slug(heading: str) -> str:
    """The anchor GitHub gives a heading: lower case, punctuation dropped, spaces as hyphens."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading.strip().lower())  # a link's text stays
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def prose_lines(text: str) -> Iterator[tuple[int, str]]:
    """(number, line) of a markdown text outside fenced code blocks."""
    fence = ""
    for number, line in enumerate(text.splitlines(), 1):
        stripped = line.lstrip()
        if stripped.startswith(("```", "~~~")):
            marker = stripped[:3]
            fence = "" if fence == marker else fence or marker
            continue
        if not fence:
            yield number, line


def anchors(path: Path, cache: dict[Path, set[str]]) -> set[str]:
    if path not in cache:
        seen: dict[str, int] = {}
        anchors_found: set[str] = set()
        for _, line in prose_lines(path.read_text(encoding="utf-8")):
            heading = re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line)
            if heading:  # a repeated heading gets -1, -2 ... as on GitHub
                base = slug(heading.group(1))
                count = seen.get(base, 0)
                seen[base] = count + 1
                anchors_found.add(f"{base}-{count}" if count else base)
        for line in path.read_text(encoding="utf-8").splitlines():  # explicit <a id="..."> / <a name="...">
            anchors_found.update(re.findall(r"<a\s+(?:id|name)=\"([^\"]+)\"", line))
        cache[path] = anchors_found
    return cache[path]


def record_findings(name: str, number: int, line: str) -> list[str]:
    """Dates and seed counts in one line of a guide or preset."""
    findings = []
    date = DATE.search(line)
    if date:
        findings.append(f"{name}:{number}: a date ({date.group()}): dated entries belong in bench/RESULTS.md")
    seeds = SEED_COUNT.search(line)
    if seeds:
        findings.append(
            f"{name}:{number}: seeds counted or named ({seeds.group()!r}): "
            "the record of runs belongs in bench/RESULTS.md"
        )
    return findings


def seed_table_findings(name: str, lines: list[tuple[int, str]]) -> list[str]:
    findings = []
    for index, (number, line) in enumerate(lines):
        if not line.lstrip().startswith("|"):
            continue
        cells = line.strip().strip("|").split("|")
        header = index + 1 < len(lines) and TABLE_RULE.match(lines[index + 1][1]) is not None
        if (header and any(SEED_CELL.fullmatch(cell) for cell in cells)) or SEED_CELL.fullmatch(cells[0]):
            findings.append(f"{name}:{number}: a seed table: tables of runs belong in bench/RESULTS.md")
    return findings


def link_findings(root: Path, path: Path, lines: list[tuple[int, str]], cache: dict[Path, set[str]]) -> list[str]:
    findings = []
    name = path.relative_to(root).as_posix()
    for number, line in lines:
        for match in LINK.finditer(re.sub(r"`[^`]*`", "", line)):
            target = match.group(1)
            if re.match(r"[a-z][a-z0-9+.-]*:", target):  # https:, mailto: ...
                continue
            file_part, _, anchor = target.partition("#")
            linked = (path.parent / file_part).resolve() if file_part else path
            if not linked.exists():
                findings.append(f"{name}:{number}: link to {target}: no such file")
            elif anchor and linked.suffix == ".md" and anchor not in anchors(linked, cache):
                findings.append(f"{name}:{number}: link to {target}: no heading #{anchor} in {file_part or name}")
    return findings


def reference_findings(root: Path, path: Path, text: str, cache: dict[Path, set[str]]) -> list[str]:
    """`docs/NAME.md#anchor` written in source, presets and schemas, read from the repository root."""
    findings = []
    for number, line in enumerate(text.splitlines(), 1):
        for match in DOC_REFERENCE.finditer(line):
            document, anchor = root / match.group(1), match.group(2)
            if not document.is_file():
                findings.append(f"{path.relative_to(root).as_posix()}:{number}: {match.group()}: no such file")
            elif anchor not in anchors(document, cache):
                findings.append(f"{path.relative_to(root).as_posix()}:{number}: {match.group()}: no such heading")
    return findings


def comments(source: str) -> Iterator[tuple[int, str]]:
    """(line number, text) of every comment and docstring line of a Python source."""
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT:
            yield token.start[0], token.string
    lines = source.splitlines()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef) and node.body:
            first = node.body[0]
            if (
                isinstance(first, ast.Expr)
                and isinstance(first.value, ast.Constant)
                and isinstance(first.value.value, str)
            ):
                for number in range(first.lineno, (first.end_lineno or first.lineno) + 1):
                    yield number, lines[number - 1]


def code_findings(root: Path, path: Path, source: str) -> list[str]:
    if not (CODE_WORDS.search(source) or DATE.search(source)):
        return []  # nothing to look for: most files, spared the tokenizer and the parser
    findings = []
    name = path.relative_to(root).as_posix()
    for number, text in sorted(set(comments(source))):
        found = CODE_WORDS.search(text) or DATE.search(text)
        if found:
            findings.append(
                f"{name}:{number}: a comment cites {found.group()!r}: state the invariant or the reason; "
                "measurements, hardware and history belong in bench/RESULTS.md"
            )
    return findings


def findings(root: Path = ROOT) -> list[str]:
    """Every broken rule, one line each, `path:line: what`."""
    found: list[str] = []
    cache: dict[Path, set[str]] = {}
    for guide in guides(root):
        name = guide.relative_to(root).as_posix()
        text = guide.read_text(encoding="utf-8")
        count = len(text.splitlines())
        if count > MAX_GUIDE_LINES:
            found.append(f"{name}: {count} lines, more than {MAX_GUIDE_LINES}: split it by topic")
        lines = list(prose_lines(text))
        for number, line in lines:
            found += record_findings(name, number, line)
        found += seed_table_findings(name, lines)
        found += link_findings(root, guide, lines, cache)
    for preset in sorted(root.glob("presets/*.pbtxt")):
        text = preset.read_text(encoding="utf-8")
        for number, line in enumerate(text.splitlines(), 1):
            found += record_findings(preset.relative_to(root).as_posix(), number, line)
        found += reference_findings(root, preset, text, cache)
    for schema in searched(root, ".proto"):
        found += reference_findings(root, schema, schema.read_text(encoding="utf-8"), cache)
    for source in searched(root, ".py"):
        relative = source.relative_to(root)
        if relative.parts[0] == "bench" or relative in EXEMPT or source.name.endswith("_pb2.py"):
            continue
        text = source.read_text(encoding="utf-8")
        found += code_findings(root, source, text)
        found += reference_findings(root, source, text, cache)
    return found


def main() -> int:
    root = Path(sys.argv[1]).resolve() if len(sys.argv) > 1 else ROOT
    problems = findings(root)
    for problem in problems:
        print(problem)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
