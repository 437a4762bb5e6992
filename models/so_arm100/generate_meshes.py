"""Generate the SO-ARM100 visual meshes (binary STL) from trimesh primitives.

Every link of the arm is drawn as a union of boxes and cylinders expressed in
that link's body frame of ``so_arm100.xml`` (metres, x forward along the arm at
the zero pose, y to the left, z up).  The parts are only concatenated, never
booleaned, so the output is cheap and fully deterministic: vertices are rounded
to 1 micrometre and the STL header is all zeros, so regenerating the files gives
byte-identical results.

Usage::

    python models/so_arm100/generate_meshes.py [OUTPUT_DIR]

OUTPUT_DIR defaults to the ``assets/`` folder next to this script.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import trimesh

Vec = Sequence[float]

CYLINDER_SECTIONS = 32

# Feetech STS3215 case: 45.2 x 24.7 x 35 mm, output shaft 11.3 mm from one end.
SERVO_LENGTH = 0.0452
SERVO_WIDTH = 0.0247
SERVO_SHAFT_OFFSET = 0.0113
SERVO_CASE_TOP = -0.004  # the horn sits on top of the case, its face at z = 0
SERVO_CASE_BOTTOM = -0.0325


def box(lo: Vec, hi: Vec) -> trimesh.Trimesh:
    """Axis-aligned box spanning the corners ``lo`` and ``hi``."""
    return trimesh.creation.box(bounds=np.array([lo, hi], dtype=float))


def cylinder(p0: Vec, p1: Vec, radius: float) -> trimesh.Trimesh:
    """Cylinder of ``radius`` whose axis runs from ``p0`` to ``p1``."""
    return trimesh.creation.cylinder(radius=radius, segment=np.array([p0, p1], dtype=float), sections=CYLINDER_SECTIONS)


def bar_xz(p0: Vec, p1: Vec, width: float, y_lo: float, y_hi: float) -> trimesh.Trimesh:
    """Flat plate in the xz-plane from ``p0`` to ``p1`` (x, z), ``width`` wide, between y_lo and y_hi."""
    (x0, z0), (x1, z1) = p0, p1
    length = float(np.hypot(x1 - x0, z1 - z0))
    plate = box((-length / 2, y_lo, -width / 2), (length / 2, y_hi, width / 2))
    angle = np.arctan2(z1 - z0, x1 - x0)
    # Rotating about +y by -angle turns +x towards +z by `angle`.
    transform = trimesh.transformations.rotation_matrix(-angle, [0.0, 1.0, 0.0])
    transform[:3, 3] = [(x0 + x1) / 2, 0.0, (z0 + z1) / 2]
    plate.apply_transform(transform)
    return plate


def side_plates(p0: Vec, p1: Vec, width: float, half_gap: float, thickness: float) -> list[trimesh.Trimesh]:
    """Two mirrored plates (left and right of the servo) joining ``p0`` to ``p1``, with round ends at ``p0``."""
    parts = []
    for sign in (1.0, -1.0):
        y_lo, y_hi = sorted((sign * half_gap, sign * (half_gap + thickness)))
        parts.append(bar_xz(p0, p1, width, y_lo, y_hi))
        parts.append(cylinder((p0[0], y_lo, p0[1]), (p0[0], y_hi, p0[1]), width / 2 + 0.002))
    return parts


def sts3215() -> list[trimesh.Trimesh]:
    """STS3215 servo: shaft on +z with the horn face at the origin, case along +x."""
    return [
        box(
            (-SERVO_SHAFT_OFFSET, -SERVO_WIDTH / 2, SERVO_CASE_BOTTOM),
            (SERVO_LENGTH - SERVO_SHAFT_OFFSET, SERVO_WIDTH / 2, SERVO_CASE_TOP),
        ),
        cylinder((0, 0, SERVO_CASE_TOP), (0, 0, -0.002), 0.006),  # shaft boss
        cylinder((0, 0, -0.002), (0, 0, 0), 0.0105),  # horn
        cylinder((0, 0, SERVO_CASE_BOTTOM), (0, 0, SERVO_CASE_BOTTOM - 0.002), 0.006),  # idler boss
    ]


def base() -> list[trimesh.Trimesh]:
    """Base: clamp plate reaching back, a cradle around the vertical pan servo."""
    return [
        box((-0.12, -0.04, 0.0), (0.035, 0.04, 0.008)),  # footprint plate
        box((-0.12, -0.03, 0.008), (-0.085, 0.03, 0.022)),  # clamp boss
        box((-0.048, 0.0135, 0.008), (0.026, 0.0195, 0.043)),  # left wall
        box((-0.048, -0.0195, 0.008), (0.026, -0.0135, 0.043)),  # right wall
        box((-0.048, -0.0195, 0.008), (-0.042, 0.0195, 0.043)),  # rear wall
        box((-0.085, -0.006, 0.008), (-0.048, 0.006, 0.02)),  # rib
    ]


def shoulder() -> list[trimesh.Trimesh]:
    """Shoulder: turntable on the pan horn and the cradle holding the lift servo."""
    return [
        cylinder((0, 0, 0), (0, 0, 0.005), 0.028),  # turntable
        box((0.005, -0.021, 0.005), (0.048, 0.021, 0.04)),  # cradle block
        box((0.014, -0.0215, 0.035), (0.047, -0.0175, 0.086)),  # idler-side cheek
        cylinder((0.0306, -0.0215, 0.074), (0.0306, -0.0255, 0.074), 0.012),  # idler pivot
    ]


def upper_arm() -> list[trimesh.Trimesh]:
    """Upper arm: two side plates from the lift horn to the elbow servo, plus a spine."""
    elbow = (0.028, 0.11257)
    return [
        *side_plates((0.0, 0.0), elbow, 0.024, 0.017, 0.004),
        bar_xz((-0.010, 0.015), (0.012, 0.085), 0.008, -0.021, 0.021),  # spine
    ]


def forearm() -> list[trimesh.Trimesh]:
    """Forearm: two side plates from the elbow horn to the wrist-flex servo, plus a spine."""
    return [
        *side_plates((0.0, 0.0), (0.1349, 0.0052), 0.024, 0.017, 0.004),
        bar_xz((0.015, -0.012), (0.10, -0.010), 0.006, -0.021, 0.021),  # spine
    ]


def wrist() -> list[trimesh.Trimesh]:
    """Wrist: U-bracket on the wrist-flex horn carrying the wrist-roll servo, whose case stands up (+z, the
    gripper servo's side): folded to rest, the wrist then hangs in front of the shoulder's lift servo."""
    return [
        *side_plates((0.0, 0.0), (0.026, 0.0), 0.026, 0.017, 0.004),
        box((0.022, -0.021, -0.014), (0.028, 0.021, 0.036)),  # servo back plate
        box((0.028, -0.015, 0.034), (0.058, 0.015, 0.038)),  # servo roof
    ]


def fixed_jaw() -> list[trimesh.Trimesh]:
    """Fixed jaw: roll flange, gripper-servo housing and the lower finger with its pad."""
    return [
        cylinder((0, 0, 0), (0.006, 0, 0), 0.02),  # roll flange
        box((0.0, -0.015, -0.016), (0.015, 0.015, 0.006)),  # neck
        box((0.011, -0.0205, 0.004), (0.062, -0.0165, 0.036)),  # servo housing wall
        box((0.006, -0.011, -0.016), (0.099, 0.011, -0.008)),  # finger
        box((0.063, -0.009, -0.008), (0.097, 0.009, 0.0)),  # pad
    ]


def moving_jaw() -> list[trimesh.Trimesh]:
    """Moving jaw, drawn closed (pads touching) relative to its pivot on the servo horn."""
    return [
        cylinder((0, 0.016, 0), (0, 0.021, 0), 0.011),  # horn disc
        bar_xz((0.0, 0.0), (0.040, -0.008), 0.012, 0.016, 0.021),  # lever on the horn side
        box((0.034, -0.008, -0.0122), (0.0746, 0.021, -0.0042)),  # finger
        box((0.0386, -0.009, -0.0202), (0.0726, 0.009, -0.0122)),  # pad
    ]


MESHES: dict[str, Callable[[], list[trimesh.Trimesh]]] = {
    "sts3215": sts3215,
    "base": base,
    "shoulder": shoulder,
    "upper_arm": upper_arm,
    "forearm": forearm,
    "wrist": wrist,
    "fixed_jaw": fixed_jaw,
    "moving_jaw": moving_jaw,
}


def build(name: str) -> bytes:
    """Return the binary STL bytes of mesh ``name``."""
    mesh = trimesh.util.concatenate(MESHES[name]())
    mesh = trimesh.Trimesh(vertices=np.round(mesh.vertices, 6), faces=mesh.faces, process=False)
    return trimesh.exchange.stl.export_stl(mesh)


def generate(out_dir: Path) -> list[Path]:
    """Write every mesh as ``<name>.stl`` into ``out_dir`` and return the paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in MESHES:
        path = out_dir / f"{name}.stl"
        path.write_bytes(build(name))
        paths.append(path)
    return paths


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir", nargs="?", type=Path, default=Path(__file__).parent / "assets")
    args = parser.parse_args()
    for path in generate(args.out_dir):
        print(f"{path} ({path.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
