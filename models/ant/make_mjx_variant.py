"""Write ant_mjx.xml from ant.xml: the Ant simplified for MJX training (see the comment it starts with)."""

import re
from pathlib import Path

HERE = Path(__file__).resolve().parent
NOTE = """<!--
  ant_mjx.xml: the Ant for MJX (GPU training), simplified the way GPU training models usually are
  (Brax's and MuJoCo Playground's Ant are built the same way). Same bodies, masses, joints and
  actuators as ant.xml; three differences:
    - only the feet touch the floor: a massless sphere at each leg tip (where the shin capsule ends)
      is the only geom that collides, so MJX solves 4 contacts instead of one or two per capsule;
    - the solver is bounded for the batched GPU solver, which runs every environment for the
      largest iteration count in the batch: Newton, 1 iteration, 4 line-search iterations,
      pyramidal friction cone, and joint damping integrated explicitly (eulerdamp off);
    - keyframe "standing": torso at 0.55 m on bent legs (ankles at 1 rad), a pose that stands on its
      feet, for tasks started from it (training.task_config.keyframe).
  Regenerate with models/ant/make_mjx_variant.py.

  Ant quadruped"""
OPTION = '<option timestep="0.01"/>'
MJX_OPTION = """<option timestep="0.01" solver="Newton" iterations="1" ls_iterations="4" cone="pyramidal">
    <flag eulerdamp="disable"/>
  </option>"""
GEOM_COLLIDES = 'contype="1" conaffinity="0" material="body"/>'
FOOT_CLASS = """contype="0" conaffinity="0" material="body"/>
    <default class="foot">
      <geom type="sphere" contype="1" mass="0"/>
    </default>"""
SHIN = re.compile(r'( *)<geom name="shin_(\d)_geom" fromto="0 0 0 (\S+) (\S+) 0"/>\n')
STANDING = """  <keyframe>
    <key name="standing" qpos="0 0 0.55 1 0 0 0  0 1  0 -1  0 -1  0 1"/>
  </keyframe>
</mujoco>"""


def add_foot(match: re.Match[str]) -> str:
    indent, leg, x, y = match.groups()
    return f'{match.group(0)}{indent}<geom name="foot_{leg}" class="foot" pos="{x} {y} 0"/>\n'


def variant(source: str) -> str:
    """The text of ant_mjx.xml made from the text of ant.xml."""
    for needed in ("<!--\n  Ant quadruped", OPTION, GEOM_COLLIDES, '<mujoco model="ant">', "</mujoco>"):
        if needed not in source:
            raise SystemExit(f"ant.xml changed: '{needed}' not found; update make_mjx_variant.py")
    text = source.replace("<!--\n  Ant quadruped", NOTE, 1).replace(OPTION, MJX_OPTION)
    text = text.replace(GEOM_COLLIDES, FOOT_CLASS, 1)
    text, feet = SHIN.subn(add_foot, text)
    if feet != 4:
        raise SystemExit(f"ant.xml changed: found {feet} shin geoms, not 4; update make_mjx_variant.py")
    return text.replace("</mujoco>", STANDING).replace('<mujoco model="ant">', '<mujoco model="ant_mjx">')


if __name__ == "__main__":
    (HERE / "ant_mjx.xml").write_text(variant((HERE / "ant.xml").read_text()))
