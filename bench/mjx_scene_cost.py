"""What each part of an MJX scene costs: raw `vmap(mjx.step)` rates of a scene and of variants of it.

    python bench/mjx_scene_cost.py                                  # the pick-and-place scene, 8192 envs (GPU)
    python bench/mjx_scene_cost.py --envs 64 --steps 2              # a quick look on CPU

Each variant is the scene with MJCF appended inside <mujoco>...</mujoco> (an <option>, a <contact>
block): the script prints, per variant, the contact slots MJX allocates per simulation (every pair
that can collide reserves its maximum number of contacts, used or not), the compile seconds and the
physics steps/s of `num_envs` simulations starting from the "home" keyframe, and the ratio to the
first variant. A faster variant is only a candidate: check that it still solves the task
(plugins/joshua-mjx/tests/test_pick_place_scripted.py) before adopting it.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import mujoco

from joshua_mjx.physics import mjx

MODELS = Path(__file__).resolve().parents[1] / "models"
SCENE = MODELS / "so_arm100" / "pick_place_mjx.xml"
# Bodies that cannot touch the cube, and arm links that cannot reach the table (the pan and lift links).
EXCLUDE = """<contact>
  <exclude body1="cube" body2="base"/><exclude body1="cube" body2="shoulder"/>
  <exclude body1="cube" body2="upper_arm"/>
  <exclude body1="world" body2="shoulder"/><exclude body1="world" body2="upper_arm"/>
</contact>"""
VARIANTS = {
    "as shipped": "",
    "pyramidal cones": '<option cone="pyramidal"/>',
    "exclusions": EXCLUDE,
    "exclusions + 4 solver iterations": EXCLUDE + '<option iterations="4" ls_iterations="8"/>',
    "exclusions + pyramidal": EXCLUDE + '<option cone="pyramidal"/>',
}


def variant_model(scene: Path, extra: str) -> mujoco.MjModel:
    """`scene` with `extra` MJCF appended, compiled (written next to the scene so that includes resolve)."""
    text = f'<mujoco model="variant"><include file="{scene.name}"/>{extra}</mujoco>'
    with tempfile.NamedTemporaryFile("w", suffix=".xml", dir=scene.parent) as handle:
        handle.write(text)
        handle.flush()
        return mujoco.MjModel.from_xml_path(handle.name)


def rate(model: mujoco.MjModel, num_envs: int, steps: int) -> tuple[int, float, float]:
    """(contact slots, compile seconds, physics steps/s) of `num_envs` simulations from the "home" keyframe."""
    mx = mjx.put_model(model)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    one = mjx.put_data(model, data)
    batch = jax.tree.map(lambda leaf: jnp.broadcast_to(leaf, (num_envs, *jnp.shape(leaf))), one)
    run = jax.jit(lambda d: jax.lax.fori_loop(0, steps, lambda _, x: jax.vmap(mjx.step, (None, 0))(mx, x), d))
    started = time.perf_counter()
    batch = jax.block_until_ready(run(batch))
    compile_seconds = time.perf_counter() - started
    best = 0.0
    for _ in range(3):
        started = time.perf_counter()
        batch = jax.block_until_ready(run(batch))
        best = max(best, steps * num_envs / (time.perf_counter() - started))
    return int(one._impl.contact.dist.shape[0]), compile_seconds, best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", type=Path, default=SCENE)
    parser.add_argument("--envs", type=int, default=8192)
    parser.add_argument("--steps", type=int, default=50, help="physics steps per timed call")
    parser.add_argument("--only", action="append", help="measure only these variants (repeatable)")
    args = parser.parse_args()
    print(f"{args.scene.name} on {jax.devices()[0]}, {args.envs} simulations")
    reference = None
    for name, extra in VARIANTS.items():
        if args.only and name not in args.only:
            continue
        contacts, compile_seconds, steps_per_second = rate(variant_model(args.scene, extra), args.envs, args.steps)
        reference = reference or steps_per_second
        print(
            f"  {name:34s} {contacts:4d} contact slots  compile {compile_seconds:5.1f} s  "
            f"{steps_per_second:>12,.0f} steps/s  {steps_per_second / reference:5.2f}x",
            flush=True,
        )


if __name__ == "__main__":
    main()
