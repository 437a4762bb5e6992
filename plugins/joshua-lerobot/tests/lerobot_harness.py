"""The test side of the lerobot harness: run tests/lerobot_side.py with the real lerobot, which `./setup.sh --dev`
installs beside the venv so that it never changes it: lerobot 0.4.4 on Python 3.11 in .cache/lerobot-site
(tests/lerobot-requirements.txt), lerobot 0.6 on 3.12 in .cache/lerobot-site-3.12 (lerobot-requirements-3.12.txt)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from importlib.metadata import distributions
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parents[3]
PYTHON_VERSION = f"{sys.version_info[0]}.{sys.version_info[1]}"
# as setup.sh names them: each site holds compiled packages for one Python
_SUFFIX = "" if PYTHON_VERSION == "3.11" else f"-{PYTHON_VERSION}"
LEROBOT_SITE = REPO / ".cache" / f"lerobot-site{_SUFFIX}"
REQUIREMENTS = Path(__file__).with_name(f"lerobot-requirements{_SUFFIX}.txt")
SIDE = Path(__file__).with_name("lerobot_side.py")
NO_TORCHVISION = Path(__file__).with_name("no_torchvision")  # its sitecustomize.py stands in for torchvision


def lerobot_version() -> str | None:
    """The version of the lerobot installed in LEROBOT_SITE, read from its metadata (nothing imported); None if
    there is none."""
    found = [dist.version for dist in distributions(path=[str(LEROBOT_SITE)]) if dist.metadata["Name"] == "lerobot"]
    return found[0] if found else None


def pinned_lerobot_version() -> str:
    """The lerobot version REQUIREMENTS pins for this Python."""
    pins = [
        line.split("==")[1].split()[0] for line in REQUIREMENTS.read_text().splitlines() if line.startswith("lerobot==")
    ]
    return pins[0]


def sac_policy_type() -> str:
    """The `type` of the SAC actor lerobot_side.py's `sac` saves: lerobot 0.6 renamed it gaussian_actor."""
    version = lerobot_version() or ""
    return "sac" if version.startswith("0.4.") else "gaussian_actor"


def lerobot_environment(tmp_path: Path) -> dict[str, str]:
    """This process's environment with the real lerobot (and the torchvision placeholder) first on PYTHONPATH,
    Hugging Face offline and its caches in `tmp_path`."""
    if not (LEROBOT_SITE / "lerobot").is_dir():
        pytest.fail(f"lerobot is not installed in {LEROBOT_SITE}: run ./setup.sh --dev")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(LEROBOT_SITE), str(NO_TORCHVISION), env.get("PYTHONPATH", "")])
    env |= {"HF_HUB_OFFLINE": "1", "HF_HOME": str(tmp_path / "hf"), "HF_LEROBOT_HOME": str(tmp_path / "hf/lerobot")}
    return env


def lerobot_python(tmp_path: Path) -> Path:
    """An executable that runs this Python with `lerobot_environment`: a user's LeRobot Python, for
    `joshua eval --lerobot-python`, while `joshua` itself runs without lerobot."""
    script = tmp_path / "lerobot-python"
    env = lerobot_environment(tmp_path)
    wanted = [name for name in sorted(env) if name.startswith(("HF_", "PYTHONPATH"))]
    exports = "".join(f"export {name}='{env[name]}'\n" for name in wanted)
    script.write_text(f"#!/bin/sh\n{exports}exec '{sys.executable}' \"$@\"\n")
    script.chmod(0o755)
    return script


def lerobot(command: str, root: Path, tmp_path: Path) -> dict[str, Any]:
    """Run tests/lerobot_side.py COMMAND ROOT with the real lerobot; its JSON answer."""
    result = subprocess.run(
        [sys.executable, str(SIDE), command, str(root)],
        env=lerobot_environment(tmp_path),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return json.loads(result.stdout.strip().splitlines()[-1])
