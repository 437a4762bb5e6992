"""Regenerate joshua_core/config_pb2.py(.pyi) from proto/joshua/config.proto.

Run `python proto/generate.py` after editing the schema; tests/test_config.py fails when the
committed code is stale. Uses the protoc bundled with the pinned grpcio-tools.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path

from grpc_tools import protoc

PROTO_ROOT = Path(__file__).resolve().parent
SCHEMA = "joshua/config.proto"
GENERATED = ("config_pb2.py", "config_pb2.pyi")


def generate(out_dir: Path) -> list[Path]:
    """Compile the schema and place the generated modules in `out_dir`; return their paths."""
    with tempfile.TemporaryDirectory() as tmp:
        args = ["protoc", f"-I{PROTO_ROOT}", f"--python_out={tmp}", f"--pyi_out={tmp}", SCHEMA]
        if protoc.main(args) != 0:
            raise SystemExit(f"protoc failed on {PROTO_ROOT / SCHEMA}")
        out_dir.mkdir(parents=True, exist_ok=True)
        written = []
        for name in GENERATED:
            target = out_dir / name
            shutil.copyfile(Path(tmp, "joshua", name), target)
            written.append(target)
    return written


if __name__ == "__main__":
    default_out = PROTO_ROOT.parent / "joshua_core"
    for path in generate(Path(sys.argv[1]) if len(sys.argv) > 1 else default_out):
        print(f"wrote {path}")
