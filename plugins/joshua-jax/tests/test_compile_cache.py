"""Compiled programs kept between runs (joshua_jax.compile_cache): where they go, that a second process reads them,
that damaged entries only warn, and that the core's switch (JOSHUA_NO_CACHE) turns the cache off. Each case is a
fresh Python process, since JAX reads its cache settings once per process."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from joshua_core.outputs import NO_CACHE_ENV_VAR
from joshua_jax import building_into

# a tiny jitted function; prints what use_compile_cache reported and the cache reads of the compile
PROGRAM = """
import json, sys
import jax, jax.numpy as jnp
from joshua_jax import cache_reads, use_compile_cache
cache = use_compile_cache()
value = float(jax.jit(lambda x: jnp.sin(x) * 2.0 + 1.0)(jnp.float32(0.5)))
warp = sys.modules.get("warp")
settings = {name: getattr(warp.config, name) for name in ("kernel_cache_dir", "cache_kernels")} if warp else None
print(json.dumps({"folder": str(cache.folder) if cache.folder else None, "describe": cache.describe(),
                  "reads": cache_reads(), "value": value, "warp": settings}))
"""
EXPECTED = 2.0 * math.sin(0.5) + 1.0
TOLERANCE = 1e-6  # float32 arithmetic


def run_program(cache_home: Path, **env: str) -> tuple[dict, str]:
    """Run PROGRAM with XDG_CACHE_HOME=cache_home and no cache folder inherited from the test run (conftest)."""
    environment = {k: v for k, v in os.environ.items() if k not in ("JAX_COMPILATION_CACHE_DIR", NO_CACHE_ENV_VAR)}
    environment |= {"XDG_CACHE_HOME": str(cache_home), "JAX_PLATFORMS": "cpu", **env}
    result = subprocess.run(
        [sys.executable, "-c", PROGRAM], env=environment, capture_output=True, text=True, timeout=120, check=True
    )
    report = json.loads(result.stdout.splitlines()[-1])
    assert abs(report["value"] - EXPECTED) < TOLERANCE, report
    return report, result.stderr


def entries(folder: Path) -> list[Path]:
    return sorted(folder.glob("*-cache"))


def test_second_run_reads_what_the_first_kept(tmp_path: Path) -> None:
    folder = tmp_path / "joshua" / "jax"
    first, _ = run_program(tmp_path)
    assert first["folder"] == str(folder) and "cold" in first["describe"]
    kept = entries(folder)
    assert kept, "the first run kept no compiled program"
    hits, requests = first["reads"]
    assert hits == 0 and requests >= 1
    second, _ = run_program(tmp_path)
    assert "warm" in second["describe"]
    hits, requests = second["reads"]
    assert hits == requests == first["reads"][1]  # every program from the cache, none compiled again
    assert entries(folder) == kept


@pytest.mark.parametrize("damage", ["truncated", "garbage", "empty"])
def test_a_damaged_entry_warns_and_compiles_again(tmp_path: Path, damage: str) -> None:
    run_program(tmp_path)
    for entry in entries(tmp_path / "joshua" / "jax"):
        data = entry.read_bytes()
        entry.write_bytes({"truncated": data[: len(data) // 2], "garbage": os.urandom(len(data)), "empty": b""}[damage])
    report, stderr = run_program(tmp_path)  # check=True: it exits 0, and the value is right (run_program)
    hits, requests = report["reads"]
    assert hits == 0 and requests >= 1
    assert "Error reading persistent compilation cache entry" in stderr, stderr


def test_joshua_no_cache_turns_it_off(tmp_path: Path) -> None:
    report, _ = run_program(tmp_path, **{NO_CACHE_ENV_VAR: "1"})
    assert report["folder"] is None and "off" in report["describe"] and report["reads"] == [0, 0]
    assert not (tmp_path / "joshua").exists()


def test_a_cache_folder_given_to_jax_is_kept(tmp_path: Path) -> None:
    given = tmp_path / "given"
    report, _ = run_program(tmp_path / "xdg", JAX_COMPILATION_CACHE_DIR=str(given))
    assert report["folder"] == str(given) and entries(given)
    assert not (tmp_path / "xdg" / "joshua").exists()


def test_warp_kernels_go_to_the_cache_folder_when_warp_is_installed(tmp_path: Path) -> None:
    """A stand-in `warp` package with Warp's two settings (warp.config.kernel_cache_dir, cache_kernels)."""
    package = tmp_path / "site" / "warp"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text(
        "import types\nconfig = types.SimpleNamespace(kernel_cache_dir=None, cache_kernels=True)\n"
    )
    path = os.pathsep.join([str(tmp_path / "site"), os.environ.get("PYTHONPATH", "")])
    report, _ = run_program(tmp_path, PYTHONPATH=path)
    assert report["warp"] == {"kernel_cache_dir": str(tmp_path / "joshua" / "warp"), "cache_kernels": True}
    off, _ = run_program(tmp_path, PYTHONPATH=path, **{NO_CACHE_ENV_VAR: "1"})
    assert off["warp"] == {"kernel_cache_dir": None, "cache_kernels": False}
    own = str(tmp_path / "own")  # a WARP_CACHE_PATH the user set is Warp's to read: left alone
    kept, _ = run_program(tmp_path, PYTHONPATH=path, WARP_CACHE_PATH=own)
    assert kept["warp"] == {"kernel_cache_dir": None, "cache_kernels": True}


WARP_PROGRAM = """
import warp as wp
from joshua_jax import use_compile_cache
use_compile_cache()
@wp.kernel
def double(values: wp.array(dtype=float)):
    values[wp.tid()] *= 2.0
values = wp.array([1.0, 2.0], dtype=float, device="cpu")
wp.launch(double, dim=2, inputs=[values], device="cpu")
print(values.numpy().tolist())
"""


def test_warp_builds_its_kernels_in_the_cache_folder(tmp_path: Path) -> None:
    pytest.importorskip("warp", reason="Warp is not installed: nothing of it to cache")
    environment = {k: v for k, v in os.environ.items() if k not in ("WARP_CACHE_PATH", NO_CACHE_ENV_VAR)}
    script = tmp_path / "double.py"  # Warp reads a kernel's source from its file
    script.write_text(WARP_PROGRAM)
    result = subprocess.run(
        [sys.executable, str(script)],
        env=environment | {"XDG_CACHE_HOME": str(tmp_path)},
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    )
    assert result.stdout.splitlines()[-1] == "[2.0, 4.0]"
    assert list((tmp_path / "joshua" / "warp").glob("*/wp_*")), "Warp kept no kernel module in the cache folder"


# builds under the lock of the folder argv[1], after saying whether it had to wait
BUILDER = """
import sys
from pathlib import Path
from joshua_jax import building_into
with building_into(Path(sys.argv[1]), "test programs"):
    print("built", flush=True)
"""


def test_a_second_process_building_into_a_cache_folder_waits_for_the_first(tmp_path: Path) -> None:
    folder = tmp_path / "cache"
    with building_into(folder, "test programs"):
        builder = subprocess.Popen(
            [sys.executable, "-c", BUILDER, str(folder)], stdout=subprocess.PIPE, text=True, env=dict(os.environ)
        )
        assert builder.stdout is not None
        first = builder.stdout.readline()  # the builder found the lock held: it says so, then waits
        assert first.startswith("joshua: waiting for another process on this host building test programs"), first
    rest, _ = builder.communicate(timeout=120)
    assert builder.returncode == 0 and rest.splitlines() == ["built"]
    # once free, the lock is taken without waiting
    alone = subprocess.run([sys.executable, "-c", BUILDER, str(folder)], capture_output=True, text=True, timeout=120)
    assert alone.stdout.splitlines() == ["built"], alone.stderr


def test_a_cache_folder_that_cannot_be_made_is_built_into_without_the_lock(tmp_path: Path) -> None:
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    entered = []
    with building_into(blocker / "cache", "test programs"):
        entered.append(True)
    assert entered == [True] and blocker.read_text() == "not a folder"
