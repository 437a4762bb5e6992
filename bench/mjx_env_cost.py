"""Where an environment step's time goes on MJX, per physics implementation and batch size.

    python bench/mjx_env_cost.py --preset so_arm100_pick_place_mjx --impl warp --num-envs 8192 16384 32768
    python bench/mjx_env_cost.py --smoke                                       # tiny, on CPU

For each batch size, in one process, after compilation (best of three timed calls):
- raw physics from the reset state, and from states reached under random actions (the arm moving and touching
  things, which is what training steps: a solver that exits early on resting worlds is faster at reset);
- an env step's frame_skip physics steps carrying only MuJoCo's integration state from one to the next (what
  `MjxEnv._advance` does on MJX-JAX) against carrying the whole Data (what it does on MuJoCo Warp);
- the whole env step under random actions (task terms, observations, autoreset).
Rates are physics steps/s, except the env step's (env steps/s; x frame_skip for physics steps/s).
"""

from __future__ import annotations

import argparse
import json
from typing import Any

import jax
from mjx_time_to_target import best_rate, environment, environment_rate, load_config, raw_physics_rate

from joshua_core.plugins import PluginHost
from joshua_mjx.batch import STEP_INPUTS
from joshua_mjx.env import MjxEnv
from joshua_mjx.physics import mjx


def moved_state(env: MjxEnv, steps: int = 50) -> Any:
    """The env's state after `steps` steps of uniform random actions from a reset."""
    shape = (env.num_envs, env.action_size)

    def step(_: int, carry: tuple[Any, jax.Array]) -> tuple[Any, jax.Array]:
        state, key = carry
        key, draw = jax.random.split(key)
        return env.step(state, jax.random.uniform(draw, shape, minval=-1.0, maxval=1.0)), key

    carry = (env.reset(jax.random.PRNGKey(0)), jax.random.PRNGKey(1))
    return jax.block_until_ready(jax.jit(lambda c: jax.lax.fori_loop(0, steps, step, c))(carry))[0]


def rates(env: MjxEnv, steps: int) -> dict[str, float]:
    """The rates the module docstring lists, for one env."""
    state = moved_state(env)
    fields = env.randomization.model_params(state.params)
    skip = env.task.frame_skip
    env_steps = max(steps // skip, 1)

    def raw(data: mjx.Data) -> mjx.Data:
        return jax.lax.fori_loop(0, steps, lambda _, d: jax.vmap(mjx.step, (None, 0))(env.mjx_model, d), data)

    def whole(data: mjx.Data) -> mjx.Data:
        return jax.lax.fori_loop(0, env_steps * skip, lambda _, d: env._physics(mjx.step, fields, d), data)

    def lean_step(data: mjx.Data) -> mjx.Data:
        def inputs_step(_: int, inputs: dict[str, jax.Array]) -> dict[str, jax.Array]:
            stepped = env._physics(mjx.step, fields, data.replace(**inputs))
            return {name: getattr(stepped, name) for name in STEP_INPUTS}

        inputs = jax.lax.fori_loop(0, skip - 1, inputs_step, {name: getattr(data, name) for name in STEP_INPUTS})
        return env._physics(mjx.step, fields, data.replace(**inputs))

    def lean(data: mjx.Data) -> mjx.Data:
        return jax.lax.fori_loop(0, env_steps, lambda _, d: lean_step(d), data)

    physics = env_steps * skip * env.num_envs
    return {
        "raw_reset": raw_physics_rate(env, steps),
        "raw_moving": best_rate(jax.jit(raw), state.data, steps * env.num_envs)[1],
        "advance_whole_data": best_rate(jax.jit(whole), state.data, physics)[1],
        "advance_integration_state": best_rate(jax.jit(lean), state.data, physics)[1],
        "env_step_random_actions": environment_rate(env),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", default="so_arm100_pick_place_mjx", help="a preset's name or a .pbtxt file")
    parser.add_argument("--impl", choices=["jax", "warp"], default="warp")
    parser.add_argument("--num-envs", type=int, nargs="+", default=[8192])
    parser.add_argument("--steps", type=int, default=20, help="physics steps per timed call")
    parser.add_argument("--smoke", action="store_true", help="tiny sizes (CPU): 8 envs, 4 steps")
    args = parser.parse_args()
    if args.smoke:
        args.num_envs, args.steps = [8], 4
    plugins = PluginHost.discover()
    results = []
    for num_envs in args.num_envs:
        config = load_config(args.preset, [f"training.mjx.impl={args.impl.upper()}"], num_envs, plugins.options())
        env = environment(config, plugins, num_envs, jax.devices()[:1])
        entry = {"num_envs": num_envs, "frame_skip": env.task.frame_skip, **rates(env, args.steps)}
        results.append(entry)
        print(json.dumps(entry), flush=True)
    for entry in results:
        line = "  ".join(f"{key} {value:,.0f}" for key, value in entry.items() if isinstance(value, float))
        print(f"{args.preset} {args.impl} {entry['num_envs']} envs: {line}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
