"""Write ant_mjx.xml from ant.xml: the same Ant with the solver bounded for MJX (see the comment it starts with)."""

from pathlib import Path

HERE = Path(__file__).resolve().parent
NOTE = """<!--
  ant_mjx.xml: the Ant for MJX (GPU training). Identical bodies, joints, actuators and contacts to
  ant.xml; only the constraint solver is bounded (Newton, 4 iterations, 8 line-search iterations)
  and the friction cone is pyramidal, as MJX's batched solver runs every environment for the
  largest iteration count in the batch. Regenerate with models/ant/make_mjx_variant.py.

  Ant quadruped"""
OPTION = '<option timestep="0.01"/>'
MJX_OPTION = '<option timestep="0.01" solver="Newton" iterations="4" ls_iterations="8" cone="pyramidal"/>'


def main() -> None:
    source = (HERE / "ant.xml").read_text()
    for needed in ("<!--\n  Ant quadruped", OPTION, '<mujoco model="ant">'):
        if needed not in source:
            raise SystemExit(f"ant.xml changed: '{needed}' not found; update make_mjx_variant.py")
    variant = source.replace("<!--\n  Ant quadruped", NOTE, 1).replace(OPTION, MJX_OPTION)
    (HERE / "ant_mjx.xml").write_text(variant.replace('<mujoco model="ant">', '<mujoco model="ant_mjx">'))


if __name__ == "__main__":
    main()
