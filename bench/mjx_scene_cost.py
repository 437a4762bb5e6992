"""What each part of an MJX scene costs: raw `vmap(mjx.step)` rates of a scene and of variants of it.

    python bench/mjx_scene_cost.py                                  # the pick-and-place scene, 8192 envs (GPU)
    python bench/mjx_scene_cost.py --envs 64 --steps 2              # a quick look on CPU
    python bench/mjx_scene_cost.py --envs 16384 32768 --only "as shipped (10 ms x 2)"

Each variant is the scene with MJCF appended inside <mujoco>...</mujoco> (an <option>), possibly an edit
of the compiled model, and a number of physics steps per 20 ms control step (the task's frame_skip for
that timestep). The script prints, per variant and number of simulations, the contact slots MJX
allocates per simulation (every pair that can collide reserves its maximum number of contacts, used or
not), the compile seconds, the physics steps/s of the simulations starting from the "home" keyframe under
random servo targets (see `rate`), the control (env) steps/s that makes, and the ratio of the latter to
the first line. A faster variant is only a candidate: check that it still solves the task
(plugins/joshua-mjx/tests/test_pick_place_scripted.py) before adopting it.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import jax
import jax.numpy as jnp
import mujoco
from mjx_time_to_target import best_rate

from joshua_mjx.physics import mjx

MODELS = Path(__file__).resolve().parents[1] / "models"
HOLD_SECONDS = 0.5  # how long a random servo target holds, on average, before the next is drawn
SCENE = MODELS / "so_arm100" / "pick_place_mjx.xml"


def cube_touches_whole_arm(model: mujoco.MjModel) -> None:
    """The cube as it was before the fingertip-only contacts: every arm collision geom touches it (its conaffinity
    1 instead of 2; see so_arm100.xml): 64 contact slots instead of 50."""
    model.geom_conaffinity[model.geom("cube").id] = 1


# name: (MJCF appended to the scene, physics steps per 20 ms control step, an edit of the compiled model)
VARIANTS = {
    "as shipped (10 ms x 2)": ("", 2, None),
    "the earlier scene (4 ms x 5, whole arm, 12 line-search)": (
        '<option timestep="0.004" ls_iterations="12"/>',
        5,
        cube_touches_whole_arm,
    ),
    "10 ms x 2, whole arm, 12 line-search": ('<option ls_iterations="12"/>', 2, cube_touches_whole_arm),
    "the cube touches the whole arm": ("", 2, cube_touches_whole_arm),
    "12 line-search iterations": ('<option ls_iterations="12"/>', 2, None),
    "5 ms x 4": ('<option timestep="0.005"/>', 4, None),
    "20 ms x 1": ('<option timestep="0.02"/>', 1, None),
    "pyramidal cones": ('<option cone="pyramidal"/>', 2, None),
    "5 solver iterations (fails the scripted controller)": ('<option iterations="5"/>', 2, None),
    "solver tolerance 1e-4": ('<option tolerance="1e-4"/>', 2, None),
}


def variant_model(scene: Path, extra: str) -> mujoco.MjModel:
    """`scene` with `extra` MJCF appended, compiled (written next to the scene so that includes resolve)."""
    text = f'<mujoco model="variant"><include file="{scene.name}"/>{extra}</mujoco>'
    with tempfile.NamedTemporaryFile("w", suffix=".xml", dir=scene.parent) as handle:
        handle.write(text)
        handle.flush()
        return mujoco.MjModel.from_xml_path(handle.name)


def rate(model: mujoco.MjModel, num_envs: int, steps: int) -> tuple[int, float, float]:
    """(contact slots, compile seconds, physics steps/s) of `num_envs` simulations from the "home" keyframe whose
    servo targets jump to random points of their ranges (each env about every HOLD_SECONDS): the arms swing apart and
    hit the table and the cube, so the constraint solver works as in training, not on arms at rest."""
    mx = mjx.put_model(model)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    one = mjx.put_data(model, data)
    batch = jax.tree.map(lambda leaf: jnp.broadcast_to(leaf, (num_envs, *jnp.shape(leaf))), one)
    low, high = jnp.asarray(model.actuator_ctrlrange[:, 0]), jnp.asarray(model.actuator_ctrlrange[:, 1])
    chance = model.opt.timestep / HOLD_SECONDS  # of a new target, per env and physics step

    def step(_: int, carry: tuple[mjx.Data, jax.Array]) -> tuple[mjx.Data, jax.Array]:
        data, key = carry
        key, when, where = jax.random.split(key, 3)
        redraw = jax.random.uniform(when, (num_envs, 1)) < chance
        target = low + (high - low) * jax.random.uniform(where, data.ctrl.shape)
        data = data.replace(ctrl=jnp.where(redraw, target.astype(data.ctrl.dtype), data.ctrl))
        return jax.vmap(mjx.step, (None, 0))(mx, data), key

    run = jax.jit(lambda carry: jax.lax.fori_loop(0, steps, step, carry))
    compile_seconds, best = best_rate(run, (batch, jax.random.PRNGKey(0)), steps * num_envs)
    return int(one._impl.contact.dist.shape[0]), compile_seconds, best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", type=Path, default=SCENE)
    parser.add_argument("--envs", type=int, nargs="+", default=[8192], help="numbers of simulations to measure")
    parser.add_argument("--steps", type=int, default=50, help="physics steps per timed call")
    parser.add_argument("--only", action="append", help="measure only these variants (repeatable)")
    args = parser.parse_args()
    print(f"{args.scene.name} on {jax.devices()[0]}")
    reference = None
    for num_envs in args.envs:
        for name, (extra, substeps, edit) in VARIANTS.items():
            if args.only and name not in args.only:
                continue
            model = variant_model(args.scene, extra)
            if edit:
                edit(model)
            contacts, compile_seconds, physics_rate = rate(model, num_envs, args.steps)
            control_rate = physics_rate / substeps
            reference = reference or control_rate
            print(
                f"  {num_envs:6d} x {name:36s} {contacts:4d} contact slots  compile {compile_seconds:5.1f} s  "
                f"{physics_rate:>12,.0f} physics steps/s  {control_rate:>11,.0f} env steps/s  "
                f"{control_rate / reference:5.2f}x",
                flush=True,
            )


if __name__ == "__main__":
    main()
