"""USD -> MuJoCo importer: `import_usd(path)` reads a composed UsdPhysics stage into a `mujoco.MjSpec` and an
`ImportReport` of warnings. See docs/usd.md (Import) for the attribute mapping."""

from joshua_usd.importer.build import Imported, import_usd
from joshua_usd.importer.mass import compile_spec
from joshua_usd.importer.report import ImportReport

__all__ = ["ImportReport", "Imported", "compile_spec", "import_usd"]
