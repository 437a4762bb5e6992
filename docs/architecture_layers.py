"""Draw docs/architecture_layers.svg: JOSHUA's distributions on floors computed from the code's real imports.

    python docs/architecture_layers.py      # rewrites docs/architecture_layers.svg

A distribution's floor is one above the highest floor of the distributions its code imports (read with `ast` by
tools/import_graph.py; imports under TYPE_CHECKING left out), so the picture follows the code: nothing here names
a floor or an edge. Each box says what the distribution registers (joshua_core/providers.json). Arrows point from
the importer to what it imports; imports of the core, which every distribution makes, are left out.
tests/test_architecture.py fails when the SVG is not what this script draws from the current code.
"""

from __future__ import annotations

import json
import sys
from html import escape
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

from import_graph import CORE, distribution_graph, floors  # noqa: E402

OUTPUT = Path(__file__).with_name("architecture_layers.svg")
WIDTH = 1000
FLOOR_HEIGHT = 110
BOX_HEIGHT = 56
MARGIN = 20
LABEL_WIDTH = 70
GAP = 12
COUNTED = {"task", "term"}  # many names: shown as a count


def description(distribution: str, provided: dict[str, list[str]]) -> str:
    """One line of what a distribution registers."""
    if distribution == CORE:
        return "config, plugin host, ABCs, task layer, run folders, CLI"
    if not provided:
        return "a library: registers nothing"
    parts = []
    for kind, names in sorted(provided.items()):
        if kind in COUNTED:
            parts.append(f"{len(names)} {kind}s")
        else:
            parts.append(f"{kind} {' '.join(names)}")
    return "; ".join(parts)


def render(root: Path = ROOT) -> str:
    """The SVG document for the code under `root`."""
    graph = distribution_graph(root)
    floor_of = floors(graph)
    catalog = json.loads((root / "joshua_core" / "providers.json").read_text(encoding="utf-8"))
    top = max(floor_of.values())
    height = MARGIN * 2 + FLOOR_HEIGHT * (top + 1) + 20
    boxes: dict[str, tuple[float, float, float]] = {}  # distribution -> (x, y, width)
    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height}" '
        f'font-family="DejaVu Sans, Arial, sans-serif" font-size="13">',
        '<defs><marker id="head" markerWidth="10" markerHeight="8" refX="5" refY="8" orient="auto-start-reverse" '
        'markerUnits="userSpaceOnUse"><path d="M0,0 L10,0 L5,8 z" fill="#6b7280"/></marker></defs>',
        f'<rect width="{WIDTH}" height="{height}" fill="white"/>',
    ]
    for floor in range(top, -1, -1):
        y = MARGIN + (top - floor) * FLOOR_HEIGHT
        names = sorted(name for name, level in floor_of.items() if level == floor)
        parts.append(
            f'<rect x="{MARGIN}" y="{y}" width="{WIDTH - 2 * MARGIN}" height="{BOX_HEIGHT + 16}" '
            f'fill="#f9fafb" stroke="#e5e7eb"/><text x="{MARGIN + 10}" y="{y + BOX_HEIGHT / 2 + 12:.0f}" '
            f'font-weight="bold">floor {floor}</text>'
        )
        inner = WIDTH - 2 * MARGIN - LABEL_WIDTH
        width = (inner - GAP * (len(names) + 1)) / len(names)
        for position, name in enumerate(names):
            x = MARGIN + LABEL_WIDTH + GAP + position * (width + GAP)
            boxes[name] = (x, y + 8, width)
    for name, imported in sorted(graph.items()):
        x, y, width = boxes[name]
        for other in sorted(imported - {CORE}):
            ox, oy, owidth = boxes[other]
            parts.append(
                f'<line x1="{x + width / 2:.0f}" y1="{y + BOX_HEIGHT:.0f}" x2="{ox + owidth / 2:.0f}" y2="{oy:.0f}" '
                'stroke="#6b7280" stroke-width="1.2" marker-end="url(#head)"/>'
            )
    for name, (x, y, width) in sorted(boxes.items()):
        text = description(name, catalog.get(name, {}))
        size = min(11.0, 1.9 * width / max(len(text), 1))
        parts.append(
            f'<rect x="{x:.0f}" y="{y:.0f}" width="{width:.0f}" height="{BOX_HEIGHT}" rx="7" fill="#ede9fe" '
            f'stroke="#374151"/><text x="{x + width / 2:.0f}" y="{y + 22:.0f}" font-weight="bold" '
            f'text-anchor="middle">{escape(name)}</text><text x="{x + width / 2:.0f}" y="{y + 42:.0f}" '
            f'font-size="{size:.1f}" text-anchor="middle">{escape(text)}</text>'
        )
    parts.append(
        f'<text x="{MARGIN}" y="{height - MARGIN}" font-size="12">Floors and arrows computed from the imports '
        "(python docs/architecture_layers.py); every distribution also imports joshua-core.</text>"
    )
    parts.append("</svg>")
    return "\n".join(parts) + "\n"


if __name__ == "__main__":
    OUTPUT.write_text(render(), encoding="utf-8")
    print(f"wrote {OUTPUT}")
