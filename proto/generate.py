"""Regenerate the Python code of every JOSHUA schema: the core's and each plugin's options.

Run `python proto/generate.py` after editing a .proto; tests/test_config.py fails when committed
code is stale. Uses the protoc bundled with the pinned grpcio-tools.

The core schema `proto/joshua/config.proto` becomes `joshua_core/config_pb2.py(.pyi)`. A plugin's
options (`<package>/options.proto`, extensions of joshua.SimulationConfig or joshua.TrainingConfig)
import it as "joshua/config.proto"; protoc writes that import as `from joshua import config_pb2`, and
this script points it at the module the core ships, `joshua_core.config_pb2`.
"""

from __future__ import annotations

import re
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from grpc_tools import protoc

PROTO_ROOT = Path(__file__).resolve().parent
REPO_ROOT = PROTO_ROOT.parent
CORE_IMPORT = re.compile(r"^from joshua import config_pb2\b", re.MULTILINE)


@dataclass(frozen=True)
class Schema:
    """One .proto: `path` inside its include folder `root`, compiled into `out_dir`."""

    root: Path
    path: str
    out_dir: Path

    def generated_names(self) -> list[str]:
        stem = Path(self.path).stem
        return [f"{stem}_pb2.py", f"{stem}_pb2.pyi"]


def _plugin_options(folder: str, package: str) -> Schema:
    root = REPO_ROOT / folder
    return Schema(root, f"{package}/options.proto", root / package)


SCHEMAS = (
    Schema(PROTO_ROOT, "joshua/config.proto", REPO_ROOT / "joshua_core"),
    _plugin_options("plugins/joshua-modes", "joshua_modes"),
    _plugin_options("plugins/joshua-mirror", "joshua_mirror"),
    _plugin_options("plugins/joshua-mjx", "joshua_mjx"),
    _plugin_options("plugins/joshua-ppo", "joshua_ppo"),
    _plugin_options("plugins/joshua-sb3", "joshua_sb3"),
    _plugin_options("plugins/joshua-usd", "joshua_usd"),
    _plugin_options("docs/examples/joshua-rk4", "joshua_rk4"),
)


def generate(schema: Schema, out_dir: Path) -> list[Path]:
    """Compile one schema and place its generated modules in `out_dir`; return their paths."""
    with tempfile.TemporaryDirectory() as tmp:
        includes = {f"-I{schema.root}", f"-I{PROTO_ROOT}"}
        args = ["protoc", *sorted(includes), f"--python_out={tmp}", f"--pyi_out={tmp}", schema.path]
        if protoc.main(args) != 0:
            raise SystemExit(f"protoc failed on {schema.root / schema.path}")
        out_dir.mkdir(parents=True, exist_ok=True)
        written = []
        for name in schema.generated_names():
            code = Path(tmp, Path(schema.path).parent, name).read_text(encoding="utf-8")
            target = out_dir / name
            target.write_text(CORE_IMPORT.sub("from joshua_core import config_pb2", code), encoding="utf-8")
            written.append(target)
    return written


def generate_all() -> list[Path]:
    """Regenerate every schema in place."""
    return [path for schema in SCHEMAS for path in generate(schema, schema.out_dir)]


if __name__ == "__main__":
    if len(sys.argv) > 1:
        raise SystemExit("usage: python proto/generate.py  (regenerates every schema in place)")
    for path in generate_all():
        print(f"wrote {path.relative_to(REPO_ROOT)}")
