"""`joshua usd export`, byte-stable output, the committed models/isaac files, and the export errors."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from pxr import Usd

from joshua_core.errors import ModelError, UsageError
from joshua_core.resources import models_dir
from joshua_usd.exporter import export_model

JOSHUA = shutil.which("joshua") or str(Path(sys.executable).with_name("joshua"))
ISAAC = models_dir() / "isaac"


def _joshua(*args: str | Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([JOSHUA, *map(str, args)], cwd=cwd, capture_output=True, text=True, timeout=120)


def test_cli_exports_a_shipped_model(tmp_path: Path) -> None:
    result = _joshua("usd", "export", "trileg/trileg.xml", "out/trileg.usd", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == f"wrote {Path('out/trileg.usd')}"
    stage = Usd.Stage.Open(str(tmp_path / "out" / "trileg.usd"))
    assert stage.GetDefaultPrim().GetName() == "trileg"


@pytest.mark.parametrize("case", ["bad model", "unwritable"])
def test_cli_errors_exit_2_with_one_line(tmp_path: Path, case: str) -> None:
    (tmp_path / "bad.xml").write_text("<mujoco><worldbody><body><geom type='nonsense'/></body></worldbody>\n</mujoco>")
    (tmp_path / "file").write_text("")
    model, out = ("bad.xml", "bad.usd") if case == "bad model" else ("ant/ant.xml", "file/ant.usd")
    result = _joshua("usd", "export", model, out, cwd=tmp_path)
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1 and result.stderr.startswith("joshua: error: ")
    assert not (tmp_path / "bad.usd").exists()


def test_rerun_is_byte_identical_and_text_even_for_usd(tmp_path: Path) -> None:
    first = export_model(models_dir() / "ant" / "ant.xml", tmp_path / "a.usd").read_bytes()
    second = export_model(models_dir() / "ant" / "ant.xml", tmp_path / "b.usd").read_bytes()
    assert first == second and first.startswith(b"#usda 1.0\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.usd", "b.usd"]  # no temporary files left


def test_usdc_is_written_as_crate(tmp_path: Path) -> None:
    out = export_model(models_dir() / "trileg" / "trileg.xml", tmp_path / "trileg.usdc")
    assert out.read_bytes().startswith(b"PXR-USDC")
    assert Usd.Stage.Open(str(out)).GetDefaultPrim().GetName() == "trileg"


def test_generate_reproduces_the_committed_isaac_models(tmp_path: Path) -> None:
    command = [sys.executable, str(ISAAC / "generate.py"), str(tmp_path)]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    for name in ("so100.usd", "so101.usd", "ant.usd", "trileg.usd"):
        stale = f"rerun models/isaac/generate.py: {name} is stale"
        assert (tmp_path / name).read_bytes() == (ISAAC / name).read_bytes(), stale


def test_errors_are_one_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco>\n<worldbody>\n<geom type='box'/>\n</worldbody>\n</mujoco>")  # a box without size
    with pytest.raises(ModelError) as error:
        export_model(bad, tmp_path / "bad.usd")
    assert "\n" not in str(error.value) and "bad.xml" in str(error.value)
    with pytest.raises(UsageError, match="write .usd, .usda or .usdc"):
        export_model(models_dir() / "ant" / "ant.xml", tmp_path / "ant.usdz")
    two = tmp_path / "two.xml"
    two.write_text(
        "<mujoco><worldbody><body><joint axis='1 0 0'/><joint axis='0 1 0'/><geom size='0.1'/></body>"
        "</worldbody></mujoco>"
    )
    with pytest.raises(ModelError, match="has 2 joints"):
        export_model(two, tmp_path / "two.usd")
