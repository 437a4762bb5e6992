"""Regenerate the Isaac (UsdPhysics) versions of JOSHUA's robots from their MJCF models.

    python models/isaac/generate.py [OUT_DIR]

writes so100.usd, so101.usd, ant.usd and trileg.usd (text USD, byte-identical on every run) into OUT_DIR,
by default this folder; a test checks that the committed files are what this script writes.
so100.usd and so101.usd are each arm alone (scene.xml adds table and floor) with the scene's cameras and their
image size.
"""

from __future__ import annotations

import sys
from pathlib import Path

import mujoco

from joshua_usd.exporter import export_model, write_model

HERE = Path(__file__).resolve().parent
MODELS = HERE.parent
ARMS = {  # the arm alone, and the scene whose cameras it takes
    "so100.usd": (MODELS / "so_arm100" / "so_arm100.xml", MODELS / "so_arm100" / "scene.xml"),
    "so101.usd": (MODELS / "so101" / "so101.xml", MODELS / "so101" / "scene.xml"),
}
SOURCES = {"ant.usd": MODELS / "ant" / "ant.xml", "trileg.usd": MODELS / "trileg" / "trileg.xml"}


def arm_with_scene_cameras(arm: Path, arm_scene: Path) -> mujoco.MjModel:
    """The arm alone, with the world cameras and offscreen size of its scene (as compiled there)."""
    scene = mujoco.MjModel.from_xml_path(str(arm_scene))
    spec = mujoco.MjSpec.from_file(str(arm))
    spec.visual.global_.offwidth = scene.vis.global_.offwidth
    spec.visual.global_.offheight = scene.vis.global_.offheight
    spec.stat.extent = scene.stat.extent  # the cameras' clipping range scales with it
    for camera in range(scene.ncam):
        if scene.cam_bodyid[camera] == 0:
            spec.worldbody.add_camera(
                name=scene.camera(camera).name,
                pos=scene.cam_pos[camera],
                quat=scene.cam_quat[camera],
                fovy=float(scene.cam_fovy[camera]),
            )
    return spec.compile()


def main(argv: list[str]) -> int:
    out_dir = Path(argv[0]) if argv else HERE
    written = [write_model(arm_with_scene_cameras(*sources), out_dir / name) for name, sources in ARMS.items()]
    written += [export_model(source, out_dir / name) for name, source in SOURCES.items()]
    for path in written:
        print(f"wrote {path} ({path.stat().st_size} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
