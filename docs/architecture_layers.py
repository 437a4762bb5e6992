"""Draw docs/architecture_layers.svg: JOSHUA's distributions as floors, imports pointing down only.

    python docs/architecture_layers.py      # rewrites docs/architecture_layers.svg

Plain SVG written by hand (no plotting library), so the picture is reproducible anywhere. The floors
and boxes below are the one description of the layering; docs/architecture.md shows the result.
"""

from __future__ import annotations

from html import escape
from pathlib import Path

OUTPUT = Path(__file__).with_name("architecture_layers.svg")
WIDTH = 980
FLOOR_HEIGHT = 130
FLOOR_GAP = 30  # room between floors for the arrows
BOX_HEIGHT = 74
MARGIN = 20
LABEL_WIDTH = 150

# Top floor first. Each box: (distribution, two short lines of what it holds, fill colour).
FLOORS: list[tuple[str, list[tuple[str, str, str, str]]]] = [
    (
        "3  modes, trainers",
        [
            ("joshua-modes", "INTERACTIVE, PASSIVE,", "OFFSCREEN", "#dbeafe"),
            ("joshua-mirror", "MIRROR (ROS 2 twin),", "mirror-replay", "#dbeafe"),
            ("joshua-sb3", "trainer sb3:", "needs NUMPY envs", "#fde68a"),
            ("joshua-ppo", "trainer ppo:", "needs JAX envs", "#fde68a"),
            ("third party", "joshua-rk4: a mode", "with its own options", "#e5e7eb"),
        ],
    ),
    (
        "2  backends",
        [
            ("joshua-mujoco", "backend mujoco: Engine,", "provides NUMPY envs", "#bbf7d0"),
            ("joshua-mjx", "backend mjx: Engine,", "provides JAX envs", "#bbf7d0"),
            ("joshua-usd", "backend usd (planned):", "USD stages on MuJoCo", "#e5e7eb"),
        ],
    ),
    (
        "1  rendering",
        [
            (
                "joshua-render",
                "GL selection, frame renderer, command overlays,",
                "video writer, display/recording, live viewer",
                "#fbcfe8",
            ),
        ],
    ),
    (
        "0  core",
        [
            (
                "joshua-core",
                "config + options, plugin host + hooks, ABCs (Engine, Backend, Mode,",
                "Trainer, EnvKind), task terms + episode bookkeeping, run folders, CLI",
                "#ddd6fe",
            ),
        ],
    ),
]


def _box(x: float, y: float, width: float, name: str, line1: str, line2: str, fill: str) -> str:
    centre = x + width / 2
    return (
        f'<rect x="{x:.0f}" y="{y:.0f}" width="{width:.0f}" height="{BOX_HEIGHT}" rx="8" '
        f'fill="{fill}" stroke="#374151"/>'
        f'<text x="{centre:.0f}" y="{y + 24:.0f}" font-weight="bold" text-anchor="middle">{escape(name)}</text>'
        f'<text x="{centre:.0f}" y="{y + 44:.0f}" font-size="12" text-anchor="middle">{escape(line1)}</text>'
        f'<text x="{centre:.0f}" y="{y + 60:.0f}" font-size="12" text-anchor="middle">{escape(line2)}</text>'
    )


def render() -> str:
    """The SVG document."""
    height = MARGIN * 2 + FLOOR_HEIGHT * len(FLOORS) + 40
    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height}" '
        f'font-family="DejaVu Sans, Arial, sans-serif" font-size="14">',
        '<defs><marker id="down" markerWidth="12" markerHeight="10" refX="6" refY="2" '
        'markerUnits="userSpaceOnUse"><path d="M0,0 L12,0 L6,10 z" fill="#374151"/></marker></defs>',
        f'<rect width="{WIDTH}" height="{height}" fill="white"/>',
    ]
    inner = WIDTH - 2 * MARGIN - LABEL_WIDTH
    for index, (label, boxes) in enumerate(FLOORS):
        y = MARGIN + index * FLOOR_HEIGHT
        parts.append(
            f'<rect x="{MARGIN}" y="{y}" width="{WIDTH - 2 * MARGIN}" height="{FLOOR_HEIGHT - FLOOR_GAP}" '
            f'fill="#f9fafb" stroke="#d1d5db"/>'
        )
        parts.append(
            f'<text x="{MARGIN + 10}" y="{y + (FLOOR_HEIGHT - FLOOR_GAP) / 2 + 5:.0f}" '
            f'font-weight="bold">{escape(label)}</text>'
        )
        gap = 12
        width = (inner - gap * (len(boxes) + 1)) / len(boxes)
        for position, (name, line1, line2, fill) in enumerate(boxes):
            x = MARGIN + LABEL_WIDTH + gap + position * (width + gap)
            parts.append(_box(x, y + 13, width, name, line1, line2, fill))
        if index < len(FLOORS) - 1:
            for arrow_x in (WIDTH * 0.3, WIDTH * 0.55, WIDTH * 0.8):
                parts.append(
                    f'<line x1="{arrow_x:.0f}" y1="{y + FLOOR_HEIGHT - FLOOR_GAP + 2}" x2="{arrow_x:.0f}" '
                    f'y2="{y + FLOOR_HEIGHT - 10}" stroke="#374151" stroke-width="2" marker-end="url(#down)"/>'
                )
    footer_y = MARGIN + len(FLOORS) * FLOOR_HEIGHT - FLOOR_GAP + 24
    parts.append(
        f'<text x="{MARGIN}" y="{footer_y}" font-size="13">'
        "Imports point down only: a floor may import the floors below it; "
        "across plugins only the names a plugin exports (its __init__ __all__).</text>"
    )
    parts.append(
        f'<text x="{MARGIN}" y="{footer_y + 18}" font-size="13">Trainers never import a backend: they ask the backend '
        "the config names for environments of the kind they need (RunContext.create_envs).</text>"
    )
    parts.append(
        f'<text x="{MARGIN}" y="{footer_y + 36}" font-size="13">Within a floor: joshua-mjx builds on joshua-mujoco '
        "(MjxEngine is a MuJoCoEngine; model compilation) through the names joshua-mujoco exports.</text>"
    )
    parts.append("</svg>")
    return "\n".join(parts) + "\n"


if __name__ == "__main__":
    OUTPUT.write_text(render(), encoding="utf-8")
    print(f"wrote {OUTPUT}")
