"""Env steps/s of a preset's compiled PPO iteration under XLA, precision and optimizer variants, against the default.

    python bench/ppo_iteration_rate.py --preset ant_train_mjx_tuned                     # GPU: every variant
    python bench/ppo_iteration_rate.py --variant default --variant "bfloat16 products"  # some of them
    python bench/ppo_iteration_rate.py --smoke                                          # tiny, on CPU

XLA reads its flags and JAX its default precision when the backend starts, so each variant runs in a
process of its own: it compiles the preset's training iteration on one device (as the trainer does), runs
--warmup iterations, then times --iterations more, dispatched back to back: the compiled iteration alone,
which is what the variants change; then `train_ppo`'s own loop (which adds, per iteration, `redraw_starts`,
one `mjx.forward` over the batch, and reading the iteration's metrics, one iteration ahead). Each process
also measures raw physics (`vmap(mjx.step)` on the same batch) under its own flags, since a flag may speed
the physics too. Prints each variant's env steps/s, its ratio to the default measured in the same run, and
the share of raw physics it reaches: of the default's and of its own; and the loop's rate. What the figures
said for tuned Ant is in docs/mjx-presets.md: the update is bound by its many small kernels, not by its
matrix products, and its policy and value passes run side by side.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from typing import Any

COMPILER_OPTIONS = "PPO_ITERATION_COMPILER_OPTIONS"  # a variant's JSON for GPU_COMPILER_OPTIONS
# name -> environment the variant's process runs with (added to this one's)
VARIANTS: dict[str, dict[str, str]] = {
    "default": {},
    "cuBLASLt epilogue fusion": {"XLA_FLAGS": "--xla_gpu_enable_cublaslt=true"},
    "Triton fusion of any product": {"XLA_FLAGS": "--xla_gpu_triton_gemm_any=true"},
    "bfloat16 products": {"JAX_DEFAULT_MATMUL_PRECISION": "bfloat16"},
    "full float32 products": {"JAX_DEFAULT_MATMUL_PRECISION": "float32"},
    "XLA command buffers off": {"XLA_FLAGS": "--xla_gpu_enable_command_buffer="},
    # joshua_ppo.iteration.GPU_COMPILER_OPTIONS (which the iteration's compilation applies over XLA_FLAGS) replaced
    "serial command buffers (XLA's default)": {COMPILER_OPTIONS: '{"xla_gpu_command_buffer_scheduling_mode": "LHS"}'},
}


def compiled_iteration(config: Any, devices: int = 1) -> tuple[Any, Any, Any, Any]:
    """(env, settings, initial state, compiled iteration) of a training config on the first `devices` devices, as
    the trainer compiles it."""
    import jax
    from mjx_time_to_target import environment

    from joshua_core.options import options_of
    from joshua_core.plugins import PluginHost
    from joshua_ppo import options_pb2
    from joshua_ppo.config_settings import ppo_settings
    from joshua_ppo.iteration import make_iteration
    from joshua_ppo.state import init_state

    settings = ppo_settings(options_of(config, options_pb2.ppo), config)
    env = environment(config, PluginHost.discover(), None, jax.devices()[:devices], True)
    state = init_state(env, seed=0, network=settings.network, optimization=settings.optimization)
    iteration = make_iteration(env, **settings.groups)
    return env, settings, state, iteration.lower(state).compile()


def measure(args: argparse.Namespace) -> dict[str, float]:
    """In a variant's process: compile, warm up, time; env steps/s and raw physics env steps/s."""
    import jax
    from mjx_time_to_target import SMOKE, load_config, raw_physics_rate

    from joshua_core.plugins import PluginHost

    if COMPILER_OPTIONS in os.environ:
        import joshua_ppo.iteration

        joshua_ppo.iteration.GPU_COMPILER_OPTIONS = json.loads(os.environ[COMPILER_OPTIONS])
    # train_ppo's loop, timed after the compiled iteration alone, compiles the same program: from this cache
    jax.config.update("jax_compilation_cache_dir", tempfile.mkdtemp(prefix="ppo-iteration-rate-"))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0)
    started = time.perf_counter()
    env, settings, state, compiled = compiled_iteration(
        load_config(args.preset, SMOKE if args.smoke else [], None, PluginHost.discover().options())
    )
    result = {"compile_seconds": time.perf_counter() - started}
    for _ in range(args.warmup):
        state, _ = jax.block_until_ready(compiled(state))
    started = time.perf_counter()
    for _ in range(args.iterations):
        state, _ = compiled(state)
    jax.block_until_ready(state)
    seconds = (time.perf_counter() - started) / args.iterations
    env_steps = env.num_envs * settings.rollout.num_steps * settings.rollout.unrolls_per_iteration
    raw = raw_physics_rate(env) / env.task.frame_skip
    loop = loop_seconds(env, settings, env_steps, args.warmup, args.iterations)
    return result | {
        "env_steps_per_second": env_steps / seconds,
        "iteration_ms": seconds * 1e3,
        "loop_env_steps_per_second": env_steps / loop,
        "raw": raw,
    }


def loop_seconds(env: Any, settings: Any, env_steps: int, warmup: int, iterations: int) -> float:
    """Seconds per iteration of `train_ppo`'s own loop (start draws, the iteration, its metrics read, one
    iteration ahead), as it reports them, over `iterations` after `warmup`; its compilation is a hit of the
    cache `measure` set. One more iteration runs and its report is left out: every earlier read waited for the
    next iteration's dispatch, which returns only once the program's last loop is launched (about 40 ms
    before tuned Ant's iteration ends), but the last read comes as soon as its iteration ends, so its interval
    is short (with it, 12 timed iterations read 7 % fast)."""
    from joshua_ppo.train import train_ppo

    seconds: list[float] = []
    train_ppo(
        env,
        **settings.groups,
        total_timesteps=env_steps * (warmup + iterations + 1),
        on_progress=lambda report, state: seconds.append(report.iteration_seconds),
    )
    return sum(seconds[warmup : warmup + iterations]) / iterations


def run_variant(args: argparse.Namespace, name: str) -> dict[str, float]:
    """One variant in a process of its own (its flags read at its start); its measurement."""
    extra = VARIANTS[name]
    env = os.environ | extra
    if "XLA_FLAGS" in extra:
        env["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {extra['XLA_FLAGS']}".strip()
    command = [sys.executable, __file__, "--measure", "--preset", args.preset]
    command += ["--warmup", str(args.warmup), "--iterations", str(args.iterations)]
    command += ["--smoke"] * args.smoke
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"variant {name!r} failed: {done.stderr.strip().splitlines()[-1:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", default="ant_train_mjx_tuned", help="a preset's name or a .pbtxt file")
    parser.add_argument("--variant", action="append", choices=sorted(VARIANTS), help="default: every variant")
    parser.add_argument("--warmup", type=int, default=3, help="iterations before the timed ones")
    parser.add_argument("--iterations", type=int, default=12, help="iterations timed")
    parser.add_argument("--smoke", action="store_true", help="tiny sizes (CPU)")
    parser.add_argument("--measure", action="store_true", help=argparse.SUPPRESS)  # a variant's own process
    args = parser.parse_args()
    if args.measure:
        print(json.dumps(measure(args)))
        return 0
    names = ["default"] + [name for name in args.variant or VARIANTS if name != "default"]
    results = {}
    for name in names:
        results[name] = run_variant(args, name)
        print(f"  {name}: {results[name]['env_steps_per_second']:,.0f} env steps/s", flush=True)
    default = results["default"]
    print(f"{args.preset}: one device, {args.iterations} iterations timed after {args.warmup}")
    for name, result in results.items():
        rate = result["env_steps_per_second"]
        print(
            f"  {name:32s} {rate:>12,.0f} env steps/s  {result['iteration_ms']:7.1f} ms/iteration  "
            f"x{rate / default['env_steps_per_second']:.3f}  {rate / default['raw']:6.1%} of raw physics "
            f"({rate / result['raw']:.1%} of its own, {result['raw']:,.0f} env steps/s)  "
            f"train_ppo's loop {result['loop_env_steps_per_second']:,.0f} env steps/s "
            f"({result['loop_env_steps_per_second'] / result['raw']:.1%} of its own raw physics)  "
            f"compile {result['compile_seconds']:.0f} s"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
