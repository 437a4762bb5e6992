"""Brax's own PPO and JOSHUA's PPO on the same MJX Ant task, one after the other in one process on one GPU.

    python bench/brax_side_by_side.py                      # Brax, JOSHUA with Brax's settings, JOSHUA tuned
    python bench/brax_side_by_side.py --brax-steps 100000000 --max-seconds 240 --json out.json
    python bench/brax_side_by_side.py --smoke              # tiny sizes on CPU: checks that everything runs

The task is JOSHUA's `ant_locomotion` on `ant/ant_mjx.xml` (the tuned preset's model, keyframe and
reward) for all three runs: Brax's `brax.training.agents.ppo.train` trains on it through a Brax `Env`
whose reset and step are JOSHUA's MJX environment for one simulation, wrapped by Brax's own training
wrappers (vmap, episode length 1000, autoreset) exactly like a Brax environment. Runs:

1. **brax**: Brax's published Ant settings (4096 envs, unroll 5, batch 2048 x 32 minibatches, 4
   updates per batch, discount 0.97, lr 3e-4, entropy 1e-2, reward scaling 10, clip 0.3, policy 4x32,
   value 5x256), evaluated by Brax's own deterministic evaluator (128 episodes) at every eval epoch.
2. **joshua-brax-settings**: JOSHUA's PPO with the same settings (`BRAX_SETTINGS` below).
3. **joshua-tuned**: JOSHUA's tuned preset `ant_train_mjx_tuned` as shipped.

JOSHUA's runs are snapshotted every --snapshot-interval iterations and evaluated afterwards on the
deterministic policy over --eval-envs whole episodes (bench/mjx_train_ant.py). Reported per run:
seconds to a deterministic return of --target (compile included; Brax's eval time left out, as Brax
leaves it out of its training walltime), env steps/s while training, the best and final deterministic
return; then the ratios JOSHUA / Brax. The raw physics rate of `vmap(mjx.step)` on each run's own batch
is measured in the same run, so each trainer's throughput is also a fraction of it.

brax 0.14.2 calls `jax.device_put_replicated`, which newer jax removed: `_shim_jax` puts it back.
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
import time
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mjx_time_to_target import environment, raw_physics_rate, train  # noqa: E402
from mjx_train_ant import evaluate_returns  # noqa: E402

from joshua_core.config import apply_override, finalize, load_preset  # noqa: E402
from joshua_core.options import options_of
from joshua_core.plugins import PluginHost  # noqa: E402
from joshua_mjx import MjxEnv  # noqa: E402
from joshua_ppo import options_pb2
from joshua_ppo.config_settings import ppo_settings

PRESET = "ant_train_mjx_tuned"
# Brax's published Ant settings as JOSHUA config overrides of the tuned preset (same task and model).
BRAX_SETTINGS = (
    "training.num_envs=4096",
    "training.num_steps=5",
    "training.ppo.unrolls_per_iteration=16",  # batch_size 2048 x 32 minibatches / 4096 envs
    "training.minibatch_size=10240",  # 2048 unrolls of 5 steps
    "training.num_epochs=4",
    "training.learning_rate=3e-4",
    "training.gamma=0.97",
    "training.clip_epsilon=0.3",
    "training.ppo.anneal_learning_rate=false",
    "training.hidden_sizes=[32, 32, 32, 32]",
)


def _shim_jax() -> None:
    """`jax.device_put_replicated` for brax 0.14.2 on jax versions that removed it."""
    if hasattr(jax, "device_put_replicated"):
        return

    def device_put_replicated(tree: Any, devices: list[jax.Device]) -> Any:
        return jax.tree.map(lambda leaf: jnp.stack([jnp.asarray(leaf)] * len(devices)), tree)

    jax.device_put_replicated = device_put_replicated


def brax_env(env: MjxEnv) -> Any:
    """A Brax `Env` for one simulation whose reset and step are `env`'s (built for one environment)."""
    from brax.envs.base import Env, State

    class JoshuaTask(Env):
        @property
        def observation_size(self) -> int:
            return env.observation_size

        @property
        def action_size(self) -> int:
            return env.action_size

        @property
        def backend(self) -> str:
            return "mjx"

        def reset(self, rng: jax.Array) -> State:
            keys = rng[None]
            data, commands, params = env._fresh_episodes(keys)  # noqa: SLF001 - the unjitted pieces, for Brax's vmap
            state = env._begin_episodes(data, commands, params, keys, jnp.zeros(1, jnp.int32))  # noqa: SLF001
            zero = jnp.zeros((), jnp.float32)
            return State(pipeline_state=state, obs=state.observation[0], reward=zero, done=zero, metrics={}, info={})

        def step(self, state: State, action: jax.Array) -> State:
            inner = env._step(state.pipeline_state, action[None])  # noqa: SLF001
            done = inner.terminated[0].astype(jnp.float32)  # truncation: Brax's EpisodeWrapper, at the same step
            return state.replace(pipeline_state=inner, obs=inner.observation[0], reward=inner.reward[0], done=done)

    return JoshuaTask()


def run_brax(config: Any, plugins: PluginHost, steps: int, num_evals: int, target: float, smoke: bool) -> dict:
    """Brax's PPO with its published Ant settings on JOSHUA's task; time to `target` from Brax's evaluator."""
    _shim_jax()
    from brax.training.agents.ppo import networks as ppo_networks
    from brax.training.agents.ppo import train as ppo

    env = brax_env(environment(config, plugins, 1, jax.devices()[:1]))
    evals: list[dict] = []
    started = time.perf_counter()
    pending: dict = {}

    def on_params(step: int, make_policy: Any, params: Any) -> None:
        pending.update(step=int(step), wall=time.perf_counter() - started)

    def on_progress(step: int, metrics: dict) -> None:
        eval_seconds = float(metrics.get("eval/walltime", 0.0))
        entry = {
            "step": int(step),
            "wall": pending.get("wall", time.perf_counter() - started) - eval_seconds,
            "return": float(metrics["eval/episode_reward"]),
            "length": float(metrics["eval/avg_episode_length"]),
            "sps": float(metrics.get("training/sps", float("nan"))),
        }
        evals.append(entry)
        print(f"  brax {entry['step']:>11,} steps  {entry['wall']:7.1f} s  return {entry['return']:8.1f}", flush=True)

    ppo.train(
        environment=env,
        num_timesteps=steps,
        num_evals=num_evals,
        reward_scaling=10,
        episode_length=env_episode_length(config, plugins),
        normalize_observations=True,
        action_repeat=1,
        unroll_length=5,
        num_minibatches=4 if smoke else 32,
        num_updates_per_batch=4,
        discounting=0.97,
        learning_rate=3e-4,
        entropy_cost=1e-2,
        num_envs=8 if smoke else 4096,
        batch_size=8 if smoke else 2048,
        num_eval_envs=8 if smoke else 128,
        deterministic_eval=True,
        seed=1,
        network_factory=functools.partial(ppo_networks.make_ppo_networks, policy_hidden_layer_sizes=(32,) * 4),
        policy_params_fn=on_params,
        progress_fn=on_progress,
    )
    trained = [entry for entry in evals if entry["step"] > 0]
    summary = summarize("brax", trained, target, compile_seconds=None)
    batch = environment(config, plugins, 8 if smoke else 4096, jax.devices()[:1])  # Brax's batch, on JOSHUA's env
    raw_env_steps = raw_physics_rate(batch) / batch.task.frame_skip
    return summary | {"fraction_of_raw_physics": summary["env_steps_per_second"] / raw_env_steps}


def env_episode_length(config: Any, plugins: PluginHost) -> int:
    return environment(config, plugins, 1, jax.devices()[:1]).task.episode_length


def run_joshua(name: str, config: Any, plugins: PluginHost, args: argparse.Namespace) -> dict:
    """JOSHUA's PPO on `config` until the training return reaches the target or the time limit."""
    settings = ppo_settings(options_of(config, options_pb2.ppo), config)
    env = environment(config, plugins, config.num_envs, jax.devices()[:1], training=True)
    outcome, snapshots = train(settings, env, args.target, args.max_seconds, args.iterations, args.snapshot_interval)
    eval_env = environment(config, plugins, args.eval_envs, jax.devices()[:1])
    evaluations = evaluate_returns(settings, eval_env, [snapshot for _, snapshot in snapshots])
    evaluated = [
        when | result | {"sps": outcome["train_steps_per_second"]}
        for (when, _), result in zip(snapshots, evaluations, strict=True)
    ]
    summary = summarize(name, evaluated, args.target, compile_seconds=outcome["compile_seconds"])
    raw_env_steps = raw_physics_rate(env) / env.task.frame_skip
    return summary | {"fraction_of_raw_physics": summary["env_steps_per_second"] / raw_env_steps}


def summarize(name: str, evaluated: list[dict], target: float, compile_seconds: float | None) -> dict:
    """Time to the target, throughput and returns of one run from its evaluated snapshots."""
    reached = next((entry for entry in evaluated if entry["return"] >= target), None)
    rates = [entry["sps"] for entry in evaluated if np.isfinite(entry["sps"])]
    summary = {
        "run": name,
        "seconds_to_target": reached and reached["wall"],
        "steps_to_target": reached and reached["step"],
        "env_steps_per_second": float(np.median(rates)) if rates else float("nan"),
        "best_return": max((entry["return"] for entry in evaluated), default=float("nan")),
        "final_return": evaluated[-1]["return"] if evaluated else float("nan"),
        "compile_seconds": compile_seconds,
        "evaluations": evaluated,
    }
    print(
        f"{name}: target {'reached at ' + format(reached['wall'], '.0f') + ' s' if reached else 'not reached'}, "
        f"{summary['env_steps_per_second']:,.0f} env steps/s, best {summary['best_return']:.0f}, "
        f"final {summary['final_return']:.0f}",
        flush=True,
    )
    return summary


def config_with(overrides: tuple[str, ...] | list[str], plugins: PluginHost) -> Any:
    loaded = load_preset(PRESET, plugins.options())
    for assignment in overrides:
        apply_override(loaded.message, assignment, plugins.options())
    return finalize(loaded).training


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--target", type=float, default=6000.0)
    parser.add_argument("--brax-steps", type=int, default=60_000_000, help="Brax's num_timesteps")
    parser.add_argument(
        "--brax-evals", type=int, default=13, help="Brax's num_evals (evaluations, the first at step 0)"
    )
    parser.add_argument("--max-seconds", type=float, default=200.0, help="time limit of each JOSHUA run")
    parser.add_argument("--iterations", type=int, help="stop each JOSHUA run after this many iterations")
    parser.add_argument("--snapshot-interval", type=int, default=10)
    parser.add_argument("--eval-envs", type=int, default=128)
    parser.add_argument("--runs", default="brax,joshua-brax-settings,joshua-tuned", help="which runs, comma-separated")
    parser.add_argument("--smoke", action="store_true", help="tiny sizes (CPU): checks that every run works")
    parser.add_argument("--json", help="write the results here")
    args = parser.parse_args()
    smoke = (
        ("training.num_envs=64", "training.minibatch_size=80", "training.ppo.unrolls_per_iteration=1")
        if args.smoke
        else ()
    )
    if args.smoke:
        args.brax_steps, args.brax_evals, args.iterations, args.eval_envs = 20_000, 2, 2, 8
    plugins = PluginHost.discover()
    print(f"devices: {jax.devices()}", flush=True)
    results = {}
    for name in args.runs.split(","):
        if name == "brax":
            results[name] = run_brax(
                config_with(smoke, plugins), plugins, args.brax_steps, args.brax_evals, args.target, args.smoke
            )
        elif name == "joshua-brax-settings":
            results[name] = run_joshua(name, config_with(BRAX_SETTINGS + smoke, plugins), plugins, args)
        elif name == "joshua-tuned":
            results[name] = run_joshua(name, config_with(smoke, plugins), plugins, args)
        else:
            parser.error(f"unknown run '{name}' (brax, joshua-brax-settings, joshua-tuned)")
    if "brax" in results:
        brax = results["brax"]
        for name, result in results.items():
            if name == "brax":
                continue
            ratios = {
                "speedup_time_to_target": (brax["seconds_to_target"] / result["seconds_to_target"])
                if brax["seconds_to_target"] and result["seconds_to_target"]
                else None,
                "throughput_ratio": result["env_steps_per_second"] / brax["env_steps_per_second"],
            }
            result["vs_brax"] = ratios
            print(f"{name} vs brax: {json.dumps(ratios)}")
    print(
        json.dumps({name: {k: v for k, v in r.items() if k != "evaluations"} for name, r in results.items()}, indent=1)
    )
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
