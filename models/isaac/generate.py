"""Regenerate the Isaac (UsdPhysics) versions of JOSHUA's robots from their MJCF models.

    python models/isaac/generate.py [OUT_DIR]

writes so100.usd, ant.usd and trileg.usd (text USD, byte-identical on every run) into OUT_DIR,
by default this folder; a test checks that the committed files are what this script writes.
"""

from __future__ import annotations

import sys
from pathlib import Path

from joshua_usd.exporter import export_model

HERE = Path(__file__).resolve().parent
MODELS = HERE.parent
SOURCES = {
    "so100.usd": MODELS / "so_arm100" / "so_arm100.xml",  # the arm alone (scene.xml adds table and floor)
    "ant.usd": MODELS / "ant" / "ant.xml",
    "trileg.usd": MODELS / "trileg" / "trileg.xml",
}


def main(argv: list[str]) -> int:
    out_dir = Path(argv[0]) if argv else HERE
    for name, source in SOURCES.items():
        written = export_model(source, out_dir / name)
        print(f"wrote {written} ({written.stat().st_size} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
