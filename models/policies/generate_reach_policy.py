"""Train the SO-ARM100 reach policy once and export it: models/policies/so_arm100_reach/{policy.onnx,policy.json}.

The `joshua deploy` test drives a simulated arm with this policy over ROS 2 and checks that the gripper reaches
its target. Training it inside the test would cost a minute or more of CPU (a short run reaches only ~7 cm), so
it is trained here from the shipped preset (`so_arm100_reach_sb3`: SB3 PPO), with 600k steps and the task's
action-rate penalty x30 (about a minute on 2 idle cores; final distance 1.7-4.4 mm), and exported by the real
`joshua export`. Run from the repository root after changing the task, its model or the
export format:

    python models/policies/generate_reach_policy.py

It prints the policy's final distance to the target (`joshua eval`, 5 episodes) before writing.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

JOSHUA = Path(sys.executable).parent / "joshua"
PRESET = "so_arm100_reach_sb3"
# The task's action-rate penalty x30: the preset's policy reaches within mm by switching its targets between
# far-apart values every step, which a real servo (and deploy's speed limit) does not follow; this one moves them
# smoothly.
SMOOTH = [
    *("--set", "training.total_timesteps=600000"),
    *("--set", "training.task_config.terms[0].name=action_rate"),
    *("--set", "training.task_config.terms[0].weight=-0.15"),
]
OUT = Path(__file__).resolve().parent / "so_arm100_reach"
KEY_ENV_VAR = "JOSHUA_CHECKPOINT_KEY_FILE"  # joshua_sb3.run_folder's: a throwaway key for a throwaway run


def joshua(*args: str, cwd: Path, env: dict[str, str]) -> None:
    """Run `joshua ARGS`, its output shown; stop on failure."""
    print("+ joshua", " ".join(args), flush=True)
    subprocess.run([str(JOSHUA), *args], cwd=cwd, env=env, check=True)


def main() -> None:
    with tempfile.TemporaryDirectory(prefix="joshua_reach_") as folder:
        work = Path(folder)
        env = {**os.environ, KEY_ENV_VAR: str(work / "checkpoint.key")}
        joshua("--preset", PRESET, *SMOOTH, "--set", "training.checkpoint_dir=runs",
               "--set", "training.run_name=reach", cwd=work, env=env)  # fmt: skip
        joshua("eval", "runs/reach", "--episodes", "5", "--no-video", cwd=work, env=env)
        # exported beside the run, then its two files copied over the committed ones: `--out` replaces only a
        # folder that joshua wrote, and the committed folder carries no output marker
        joshua("export", "runs/reach", "--out", "exported", cwd=work, env=env)
        OUT.mkdir(exist_ok=True)
        for name in ("policy.onnx", "policy.json"):
            shutil.copyfile(work / "exported" / name, OUT / name)
    print(f"wrote {OUT / 'policy.onnx'} and {OUT / 'policy.json'}")


if __name__ == "__main__":
    main()
