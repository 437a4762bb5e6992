"""LeRobot calibration files (`--calibration` of lerobot-export, lerobot-units and deploy, all read by
`read_calibration`): a file that does not read is one line, exit 2; a range no SO-100 servo gives is read with a
one-line warning."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from joshua_lerobot.joints import SO100_JOINTS, read_calibration

MOTORS = [name.removesuffix(".pos") for name in SO100_JOINTS]


def calibration(tmp_path: Path, **ranges: tuple[int, int]) -> Path:
    """A calibration file with every motor over 1000..3000 ticks, except `ranges` (motor -> (min, max))."""
    motors = {
        motor: {"id": i + 1, "drive_mode": 0, "homing_offset": 0, "range_min": low, "range_max": high}
        for i, motor in enumerate(MOTORS)
        for low, high in [ranges.get(motor, (1000, 3000))]
    }
    path = tmp_path / "arm.json"
    path.write_text(json.dumps(motors))
    return path


def test_a_deeply_nested_calibration_is_one_line(tmp_path: Path) -> None:
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)  # json.loads recurses past Python's limit
    command = [str(Path(sys.executable).parent / "joshua"), "lerobot-units", str(tmp_path), "--calibration", str(deep)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr[-2000:]
    assert f"{deep}: cannot read the LeRobot calibration: nested too deeply" in done.stderr


@pytest.mark.parametrize(
    ("ranges", "problem"),
    [
        ({"elbow_flex": (-10, 3000)}, "range -10..3000 lies outside the servo's 0..4095 ticks"),
        ({"gripper": (2000, 4100)}, "range 2000..4100 lies outside the servo's 0..4095 ticks"),
        ({"wrist_flex": (2000, 2001)}, "range 2000..2001 spans 1 tick(s), under a degree"),
    ],
)
def test_a_range_no_servo_gives_is_read_with_a_warning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], ranges: dict[str, tuple[int, int]], problem: str
) -> None:
    path = calibration(tmp_path, **ranges)
    (motor, (low, high)), *_ = ranges.items()
    read = read_calibration(path)
    assert (read[motor].range_min, read[motor].range_max) == (low, high)
    warning = capsys.readouterr().err
    assert warning == f"joshua: warning: {path}: motor '{motor}': {problem}; is it the arm's calibration?\n"


def test_a_plausible_calibration_reads_without_a_word(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    read_calibration(calibration(tmp_path, wrist_roll=(0, 4095), gripper=(2000, 2011)))  # a full turn; a degree
    assert capsys.readouterr().err == ""
