"""Time-to-target of a JAX trainer (PPO, TD3 or SAC: --trainer) on MJX for any task preset (success rate or return),
against raw MJX physics, in one run.

    python bench/mjx_time_to_target.py --preset so_arm100_pick_place_mjx --metric success --target 0.9 --out out/pp
    python bench/mjx_time_to_target.py --preset so_arm100_pick_place_mjx --trainer td3 --out out/pp_td3
    python bench/mjx_time_to_target.py --preset trileg_train_mjx --metric return --target 2000 --out out/trileg
    python bench/mjx_time_to_target.py --preset so_arm100_pick_place_mjx --smoke --out /tmp/smoke   # tiny, on CPU

Training stops at the first snapshot (every --snapshot-interval iterations) whose deterministic value reaches
the target, at --max-seconds or --iterations, or when the training value (the training return, or the success
rate of the episodes that ended in the iteration: exploration noise included) reaches --stop-at. That defaults
to the target for returns (the deterministic return runs ahead of the training return) and to never for success
rates, which run the other way: on pick-and-place the training success reached 0.906 while the deterministic
success of the same policy was 0.81. Each snapshot is evaluated as it is taken, with the deterministic policy
over --eval-envs whole episodes: the success rate with its 95 % Wilson interval (tasks with a `success` metric)
and the mean return with its 95 % Student t interval, by joshua_core.statistics as `joshua eval` reports them.
The time to the target is the training wall time (compile included, evaluations left out) of the first
snapshot whose deterministic value reaches it.

Prints a few lines: time to target (with and without compile), training env steps/s, raw physics steps/s of
`vmap(mjx.step)` on the same batch measured in the same run (after training) and their ratio, and the env
steps/s of the environment alone under random actions (what PPO costs on top of the task); writes
OUT/time_to_target.json (with every iteration's return and update metrics, `iterations`: a collapse shows there
first) and OUT/time_to_target.png (the metric and its interval against wall time). At every
snapshot it keeps the training state in OUT/state and the snapshots so far in the JSON, which --resume OUT
continues in a later run, also after a run stopped from outside (for targets further away than one sitting:
its wall times go on from the first run's, and the second compilation counts).
bench/mjx_train_ant.py is this bench for Ant, with its own figures (and throughput scaling over devices).

With --teacher-preset P, a teacher is trained first (`joshua --preset P`, --teacher-steps env steps, into
OUT/teacher) and the run learns beside it (training.ppo.teacher); the JSON and the summary then give the time to
the target with the teacher's whole wall time (its start-up and compile included) added, as a user waits for both:

    python bench/mjx_time_to_target.py --preset so_arm100_pick_place_pixels --target 0.8 \
        --teacher-preset so_arm100_pick_place_mjx --teacher-steps 160000000 --out out/pixels
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import jax
import numpy as np
from time_to_target_report import METRICS, normaliser_line, plot_curve, summary_lines

from joshua_core.atomic import atomic_write_bytes, atomic_write_json, json_safe
from joshua_core.config import apply_override, finalize, load_file, load_preset
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.defaults import training_output_dir
from joshua_core.interrupts import reported
from joshua_core.json_files import read_json_object
from joshua_core.options import OptionSet, options_of
from joshua_core.plugins import PluginHost
from joshua_core.run_context import RunContext
from joshua_core.statistics import SUCCESS_METRIC, summarize
from joshua_core.tasks import METRIC_PREFIX, REWARD_PREFIX
from joshua_mjx import MjxEnv, Physics
from joshua_mjx.physics import mjx
from joshua_ppo import offpolicy_iteration, offpolicy_train, options_pb2
from joshua_ppo.checkpoints import checkpoint_payloads, load_state, resume_payloads, write_payloads
from joshua_ppo.config_settings import PpoSettings, ppo_settings
from joshua_ppo.envs import environment as ppo_environment
from joshua_ppo.normalizer import RunningStatistics
from joshua_ppo.offpolicy_settings import ALGORITHMS, offpolicy_settings
from joshua_ppo.policy import deterministic_policy
from joshua_ppo.rollout import Act, collect, episode_results, make_rollout
from joshua_ppo.state import Progress, TrainingState, abstract_state
from joshua_ppo.teacher import Teacher, load_teacher
from joshua_ppo.train import IterationReport, train_ppo

# --smoke: a tiny run that exercises every stage on a CPU in a minute or two (the figures mean nothing).
SMOKE = ["training.num_envs=8", "training.num_steps=5", "training.minibatch_size=40", "training.num_epochs=1"]


TRAINERS = ("ppo", *ALGORITHMS)


@dataclass(frozen=True)
class Learner:
    """What the bench needs of a trainer (--trainer): its settings, its deterministic policy and the shapes of what
    that policy reads, its training loop, and its state's saving and loading (for --resume)."""

    name: str
    settings: Any  # PpoSettings or OffPolicySettings
    act: Callable[[MjxEnv], Act]
    shapes: Callable[[MjxEnv], tuple[Any, Any]]  # the abstract (params, normalizer) the policy reads
    fit: Callable[..., Any]  # (env, resume, on_progress, teacher) -> None, stopped by TargetReached
    payloads: Callable[[Any, Progress], dict[str, Any]]
    load: Callable[[Path, MjxEnv], tuple[Any, Progress]]


def learner(name: str, config: TrainingConfig) -> Learner:
    """The trainer `name` with the config's settings."""
    if name == "ppo":
        settings = ppo_settings(options_of(config, options_pb2.ppo), config)

        def ppo_shapes(env: MjxEnv) -> tuple[Any, Any]:
            shapes = abstract_state(env, network=settings.network, optimization=settings.optimization)
            return shapes.params, shapes.normalizer

        def ppo_fit(env: MjxEnv, resume: Any, on_progress: Callable, teacher: Teacher | None) -> None:
            train_ppo(env, **settings.groups, total_timesteps=settings.total_timesteps, seed=settings.seed,
                      resume=resume, on_progress=on_progress, teacher=teacher)  # fmt: skip

        return Learner(
            name,
            settings,
            lambda env: deterministic_policy(env, settings.network),
            ppo_shapes,
            ppo_fit,
            checkpoint_payloads,
            lambda folder, env: load_state(folder, env, settings),
        )
    settings = offpolicy_settings(options_of(config, options_pb2.offpolicy), config)

    def offpolicy_shapes(env: MjxEnv) -> tuple[Any, Any]:
        shapes = offpolicy_iteration.abstract_state(env, settings)
        return shapes.params, shapes.normalizer

    def offpolicy_fit(env: MjxEnv, resume: Any, on_progress: Callable, teacher: Teacher | None) -> None:
        offpolicy_train.train_offpolicy(env, settings, resume=resume, on_progress=on_progress)

    return Learner(
        name,
        settings,
        lambda env: offpolicy_train.offpolicy_policy(env, settings),
        offpolicy_shapes,
        offpolicy_fit,
        offpolicy_train.checkpoint_payloads,
        lambda folder, env: offpolicy_train.load_state(folder, env, settings, resume_payloads(folder)),
    )


class TargetReached(Exception):
    """Stops training once the target is reached (or the time, iteration or step budget is spent)."""


class Resumed(NamedTuple):
    """Where an earlier run of this bench stopped: its training state and counters, and its outcome."""

    state: TrainingState
    progress: Progress
    outcome: dict[str, Any]


def resume_from(folder: Path, env: MjxEnv, trainer: Learner) -> Resumed:
    """The run saved in `folder` (an earlier --out), on `env` (its environments freshly reset)."""
    state, progress = trainer.load(folder / "state", env)
    return Resumed(state, progress, read_json_object(folder / "time_to_target.json", "the bench's record"))


def evaluated(resume: Resumed | None, taken: list[dict], results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The run's snapshot records: the resumed run's, then each snapshot taken here (step, wall) with its
    evaluation."""
    earlier = resume.outcome["snapshots"] if resume else []
    return earlier + [when | result for when, result in zip(taken, results, strict=True)]


Keep = Callable[[TrainingState, Progress, dict[str, float], list[dict], list[dict]], None]


def keeper(out: Path, evaluator: SnapshotEvaluator, resume: Resumed | None, trainer: Learner) -> Keep:
    """What `train` calls at every snapshot: the training state in OUT/state (as a checkpoint saves it) and, in
    OUT/time_to_target.json, the snapshots evaluated so far and the iterations' trace, with the wall and compile
    seconds that --resume reads; the end of the run replaces that JSON with the whole outcome."""

    def keep(
        state: TrainingState, progress: Progress, seconds: dict[str, float], taken: list[dict], iterations: list[dict]
    ) -> None:
        (out / "state").mkdir(parents=True, exist_ok=True)
        write_payloads(out / "state", trainer.payloads(state, progress))
        partial = {"wall_seconds": seconds["wall"], "compile_seconds": seconds["compile"], "partial": True}
        records = evaluated(resume, taken, evaluator.results)
        atomic_write_json(
            out / "time_to_target.json", json_safe(partial | {"snapshots": records, "iterations": iterations})
        )

    return keep


def best_rate(run: Any, carry: Any, items: int) -> tuple[float, float]:
    """(compile seconds, best items/s of three timed calls) of `run`, a compiled function of `carry` that returns
    its next `carry` and does `items` units of work per call."""
    started = time.perf_counter()
    carry = jax.block_until_ready(run(carry))
    compile_seconds, best = time.perf_counter() - started, 0.0
    for _ in range(3):
        started = time.perf_counter()
        carry = jax.block_until_ready(run(carry))
        best = max(best, items / (time.perf_counter() - started))
    return compile_seconds, best


def raw_physics_rate(env: MjxEnv, steps: int = 50) -> float:
    """Physics steps/s of `vmap(mjx.step)` on env's batch, sharded the same way (after compilation)."""
    state = env.reset(jax.random.PRNGKey(0))

    @jax.jit
    def run(data: mjx.Data) -> mjx.Data:
        return jax.lax.fori_loop(0, steps, lambda _, d: jax.vmap(mjx.step, (None, 0))(env.mjx_model, d), data)

    return best_rate(run, state.data, steps * env.num_envs)[1]


def lean_physics_rate(env: MjxEnv, steps: int = 50) -> float:
    """Physics steps/s as `MjxEnv.step` runs them (its `_advance`): of each env step's frame_skip steps, only
    MuJoCo's integration state goes on to the next, so the steps before the last leave out what the last
    recomputes. A stricter reference than `raw_physics_rate` for the share of physics training reaches (the
    same work, done leaner)."""
    state = env.reset(jax.random.PRNGKey(0))
    fields = env.randomization.model_params(state.params)  # each environment's randomized model, as step has it
    env_steps = steps // env.task.frame_skip
    run = jax.jit(lambda data: jax.lax.fori_loop(0, env_steps, lambda _, d: env._advance(fields, d), data))
    return best_rate(run, state.data, env_steps * env.task.frame_skip * env.num_envs)[1]


def environment_rate(env: MjxEnv, steps: int = 20) -> float:
    """Env steps/s of `env.step` alone under uniform random actions (after compilation): the task's terms,
    resets and physics with the arm moving and touching things, and no policy. Between it and the training
    rate lies PPO's own cost; between it and `raw_physics_rate` the task's and what motion costs the solver."""
    shape = (env.num_envs, env.action_size)

    def step(_: int, carry: tuple[Any, jax.Array]) -> tuple[Any, jax.Array]:
        state, key = carry
        key, draw = jax.random.split(key)
        return env.step(state, jax.random.uniform(draw, shape, minval=-1.0, maxval=1.0)), key

    run = jax.jit(lambda carry: jax.lax.fori_loop(0, steps, step, carry))
    carry = (env.reset(jax.random.PRNGKey(0)), jax.random.PRNGKey(1))
    return best_rate(run, carry, steps * env.num_envs)[1]


Snapshot = tuple[Any, RunningStatistics]  # host copies of a policy's parameters and observation normaliser


class SnapshotEvaluator:
    """Evaluates each snapshot as it is taken, on `env`'s deterministic episodes (one compiled rollout for
    all), so that training can stop at the first snapshot whose value reaches the target; it times itself,
    and the training wall time leaves that time out. The rollout compiles in a thread from the start, beside
    the training's own compilation, instead of at the first snapshot (about a minute on pick-and-place)."""

    def __init__(self, trainer: Learner, env: MjxEnv, value_key: str, target: float) -> None:
        rollout = make_rollout(env, trainer.act(env), env.task.episode_length)
        params, normalizer = trainer.shapes(env)
        key = jax.eval_shape(lambda: jax.random.PRNGKey(1))
        # traced here, compiled in the thread (XLA's compilation is what takes the time)
        self.compiling = ThreadPoolExecutor(1).submit(rollout.lower(params, normalizer, key).compile)
        # the compiled rollout does not hold the env, but reads the Warp buffers of its cameras' render contexts,
        # which go with the env: kept alive here (else "FFI callback error: KeyError" at the first snapshot)
        self.env = env
        self.value_key, self.target = value_key, target
        self.seconds = 0.0
        self.results: list[dict[str, Any]] = []

    def __call__(self, snapshot: Snapshot) -> bool:
        """Evaluate one snapshot (as `evaluate_snapshots` does); whether it reaches the target."""
        started = time.perf_counter()
        raw = jax.device_get(self.compiling.result()(*snapshot, jax.random.PRNGKey(1)))
        self.results.append(summarize(episode_results(collect(raw))))
        self.seconds += time.perf_counter() - started
        value = self.results[-1][self.value_key]
        print(f"  snapshot: deterministic {self.value_key} {value:.4g} (evaluations so far {self.seconds:.1f} s)")
        return value >= self.target


def train(
    trainer: Learner,
    env: MjxEnv,
    target: float,
    max_seconds: float,
    iterations: int | None,
    snapshot_interval: int = 0,
    metric: str = "return",
    evaluator: SnapshotEvaluator | None = None,
    resume: Resumed | None = None,
    keep: Keep | None = None,
    teacher: Teacher | None = None,
) -> tuple[dict, list[tuple[dict, Snapshot]]]:
    """Train until the training value of `metric` reaches `target` (the stopping value), the time limit, the
    iteration limit or (with an evaluator) the first snapshot whose deterministic value reaches its target.

    Returns the outcome and snapshots of the policy every `snapshot_interval` iterations and at the
    end, each with its step and wall seconds (evaluations left out), for `evaluate_snapshots` where no
    evaluator has evaluated them. `resume` continues an earlier run (its wall time counted, its compile added);
    `keep` gets the training state, its counters and the wall and compile seconds at every snapshot (after its
    evaluation), so that a run stopped from outside (a time limit) can be resumed from its last snapshot; `teacher`:
    the policy the config's training.ppo.teacher names, loaded."""
    training_key = METRICS[metric][0]
    started = time.perf_counter()
    earlier = resume.outcome if resume else {"wall_seconds": 0.0, "compile_seconds": 0.0}

    def evaluation_seconds() -> float:
        """Time spent evaluating so far: left out of every wall time."""
        return evaluator.seconds if evaluator else 0.0

    def compile_seconds() -> float:
        """This run's compile (nan before its first iteration) added to the resumed run's."""
        return earlier["compile_seconds"] + (log[0]["compile"] if log else float("nan"))

    log: list[dict] = []
    snapshots: list[tuple[dict, Snapshot]] = []

    def trace() -> list[dict]:
        """Every iteration's entry: the resumed run's, then this run's."""
        return earlier.get("iterations", []) + log

    def on_progress(report: IterationReport, state: TrainingState) -> None:
        metrics = report.metrics
        wall = earlier["wall_seconds"] + report.wall_seconds - evaluation_seconds()
        entry = {
            "step": report.env_steps,
            "wall": wall,
            "sps": report.steps_per_second,
            "return": metrics["mean_return"],
            "value": metrics.get(training_key, float("nan")),
            "episodes": metrics["episodes"],
            "compile": report.compile_seconds,
            # the update's health, per iteration: a collapse shows here first (a KL or value-loss spike)
            **{name: metrics[name] for name in UPDATE_TRACE if name in metrics},
        }
        log.append(entry)
        reached = metrics["episodes"] > 0 and entry["value"] >= target
        out_of_budget = wall > max_seconds or (iterations is not None and report.iteration >= iterations)
        stopping = reached or out_of_budget or report.env_steps >= report.total_steps
        if report.iteration % 10 == 0 or stopping:
            print(
                f"  it {report.iteration:4d}  {report.env_steps:>11,} steps  {wall:7.1f} s  "
                f"{report.steps_per_second:>10,.0f} steps/s  return {metrics['mean_return']:8.1f}  "
                + (f"{metric} {entry['value']:.3f}  " if metric != "return" else "")
                + f"length {metrics['mean_length']:6.1f}  "
                + " ".join(f"{name} {metrics[name]:.4g}" for name in PRINTED if name in metrics)
                + "  "
                + (f"teacher_kl {metrics['teacher_kl']:.3f}  " if "teacher_kl" in metrics else "")
                + (f"kl_stopped {metrics['kl_stopped']:.2f}  " if "kl_stopped" in metrics else "")
                + " ".join(
                    f"{key.removeprefix(REWARD_PREFIX)} {value:.1f}"
                    for key, value in metrics.items()
                    if key.startswith(REWARD_PREFIX)
                )
                # the task's other metrics, e.g. a randomization curriculum's strength
                + "".join(
                    f"  {key.removeprefix(METRIC_PREFIX)} {value:.3g}"
                    for key, value in metrics.items()
                    if key.startswith(METRIC_PREFIX) and key != training_key
                ),
                flush=True,
            )
        if stopping or (snapshot_interval > 0 and report.iteration % snapshot_interval == 0):
            # a host copy, off the device's memory
            snapshots.append(
                ({"step": report.env_steps, "wall": wall}, jax.device_get((state.params, state.normalizer)))
            )
            print(normaliser_line(env.task.observation_layout, snapshots[-1][1][1].variance))
            stopping = (evaluator is not None and evaluator(snapshots[-1][1])) or stopping
            if keep is not None:
                seconds = {"wall": wall, "compile": compile_seconds()}
                taken = [when for when, _ in snapshots]
                keep(state, Progress(report.iteration, report.env_steps), seconds, taken, trace())
        if stopping:
            raise TargetReached  # or out of time, iterations or steps

    try:
        trainer.fit(env, resume and (resume.state, resume.progress), on_progress, teacher)
    except TargetReached:
        pass
    steady = [entry["sps"] for entry in log[1:]] or [entry["sps"] for entry in log]
    reached = [entry for entry in log if entry["episodes"] > 0 and entry["value"] >= target]
    return {
        "wall_seconds": earlier["wall_seconds"] + time.perf_counter() - started - evaluation_seconds(),
        "evaluation_seconds": evaluation_seconds(),
        "compile_seconds": compile_seconds(),
        "train_steps_per_second": sorted(steady)[len(steady) // 2],
        "env_steps": log[-1]["step"] if log else 0,
        "final_return": next((e["return"] for e in reversed(log) if e["episodes"] > 0), float("nan")),
        f"training_{metric}_reached_target_at_seconds": reached[0]["wall"] if reached else None,
        "iterations": trace(),
    }, snapshots


# an iteration's update metrics kept in the JSON's per-iteration trace (`iterations`): PPO's, then the off-policy
# trainers'
UPDATE_TRACE = ("approx_kl", "kl_stopped", "clip_fraction", "action_std", "value_loss", "learning_rate", "policy_loss",
                "q_mean", "alpha", "entropy")  # fmt: skip
# those printed every 10 iterations, where the trainer reports them
PRINTED = ("action_std", "approx_kl", "learning_rate", "value_loss", "clip_fraction", "q_mean", "alpha", "entropy")


def evaluate_snapshots(settings: PpoSettings, env: MjxEnv, snapshots: list[Snapshot]) -> list[dict[str, Any]]:
    """Each snapshot's evaluation (`joshua_core.statistics.summarize`: mean return and length, final metrics,
    success rate, 95 % intervals) over one episode per environment of `env`, under the policy's mean (no
    exploration noise): all snapshots in one compiled program, one after another (`lax.map`). Not vmapped:
    that multiplies the worlds of every physics call, and MuJoCo Warp's contact arrays, sized for the env's
    worlds, then overflow (Ant's deterministic episodes on Warp ended after 6 steps)."""
    rollout = make_rollout(env, deterministic_policy(env, settings.network), env.task.episode_length)
    stacked = jax.tree.map(lambda *leaves: np.stack(leaves), *snapshots)
    key = jax.random.PRNGKey(1)
    raw = jax.device_get(jax.jit(lambda s: jax.lax.map(lambda p: rollout(p[0], p[1], key), s))(stacked))
    return [summarize(episode_results(collect(jax.tree.map(lambda x, i=i: x[i], raw)))) for i in range(len(snapshots))]


def environment(
    config: TrainingConfig,
    plugins: PluginHost,
    num_envs: int | None,
    devices: list[jax.Device],
    training: bool = False,
) -> MjxEnv:
    """The config's JAX environments as the PPO trainer gets them (`joshua_ppo.envs.environment`, through
    `RunContext.create_envs`): `num_envs` (None: the config's, else PPO's default) spread over `devices`;
    `training`: the ones PPO learns on, with desynchronised episodes unless the config synchronizes them."""
    context = RunContext(plugins, Path(training_output_dir(config)))
    return ppo_environment(config, context, num_envs, devices, training_envs=training)


def load_config(preset: str, assignments: list[str], num_envs: int | None, options: OptionSet) -> TrainingConfig:
    """The preset's (or a .pbtxt file's) finalized training config with `--set` and `--num-envs` applied;
    `options`: the plugins' (`PluginHost.options()`)."""
    loaded = load_file(preset, options) if preset.endswith(".pbtxt") else load_preset(preset, options)
    for assignment in assignments:
        apply_override(loaded.message, assignment, options)
    config = finalize(loaded).training
    if num_envs:
        config.num_envs = num_envs
    return config


IMPLS = ("jax", "warp")


def impl_assignment(impl: str | None) -> list[str]:
    """The --set that makes the environments step with `impl` (training.mjx.impl; None: the preset's)."""
    return [f"training.mjx.impl={impl.upper()}"] if impl else []


def stop_at(args: argparse.Namespace) -> float:
    """The training value that stops training early: --stop-at, else the target for returns and never for
    success rates (see the module's docstring)."""
    if args.stop_at is not None:
        return args.stop_at
    return args.target if args.metric == "return" else float("inf")


def train_teacher(args: argparse.Namespace) -> float:
    """Train the teacher with `joshua --preset` into OUT/teacher, with the run's training.seed (a seed stands for the
    whole recipe), point the run's training.ppo.teacher at it (an added --set) and return its wall seconds, start-up
    included. With --smoke it trains 32 steps of 4 envs."""
    folder = (args.out / "teacher").resolve()
    steps = 32 if args.smoke else args.teacher_steps
    overrides = {"total_timesteps": steps, "checkpoint_dir": folder, "run_name": "teacher"}
    overrides |= {"ppo.video_interval": -1, "ppo.viewer": "OFF"}
    if args.smoke:
        overrides |= {"num_envs": 4, "num_steps": 4, "minibatch_size": 8}
    command = [sys.executable, "-m", "joshua_core.cli", "--preset", args.teacher_preset]
    command += [argument for name, value in overrides.items() for argument in ("--set", f"training.{name}={value}")]
    command += [argument for item in args.set if item.startswith("training.seed=") for argument in ("--set", item)]
    started = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - started
    if done.returncode != 0:
        raise SystemExit(f"the teacher's training failed (exit {done.returncode}): {done.stderr.strip()[-500:]}")
    print(done.stdout.strip().splitlines()[-1], flush=True)  # its summary line
    args.set.append(f"training.ppo.teacher.run={folder / 'teacher'}")
    return seconds


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Train, measure raw physics, evaluate the snapshots; the outcome as one JSON-ready dict."""
    plugins = PluginHost.discover()
    config = load_config(
        args.preset,
        (SMOKE if args.smoke else []) + args.set + impl_assignment(args.impl),
        args.num_envs,
        plugins.options(),
    )
    config.trainer = args.trainer  # the off-policy settings are those of the algorithm it names
    trainer = learner(args.trainer, config)
    Physics.from_training(config).leave_memory_to_warp()  # before jax.devices() starts JAX's backends
    devices = jax.devices()
    print(f"devices: {devices}  preset {args.preset}, {args.trainer}: {trainer.settings}", flush=True)
    env = environment(config, plugins, None, devices, training=True)
    if args.metric == "success" and SUCCESS_METRIC not in [term.name for term in env.task.metric_terms]:
        raise SystemExit(f"task {config.task} has no {SUCCESS_METRIC} metric: use --metric return")
    value_key = METRICS[args.metric][1]
    eval_envs = -(-args.eval_envs // len(devices)) * len(devices)
    evaluator = SnapshotEvaluator(trainer, environment(config, plugins, eval_envs, devices), value_key, args.target)
    resume = resume_from(args.resume, env, trainer) if args.resume else None
    settings = trainer.settings
    teacher = None
    if args.trainer == "ppo" and settings.teacher is not None:
        context = RunContext(plugins, Path(training_output_dir(config)))
        teacher = load_teacher(settings.teacher, env, config.task, context, settings.network)
    outcome, snapshots = train(
        trainer,
        env,
        stop_at(args),
        args.max_seconds,
        args.iterations,
        args.snapshot_interval,
        args.metric,
        evaluator,
        resume,
        keep=keeper(args.out, evaluator, resume, trainer),
        teacher=teacher,
    )
    raw = raw_physics_rate(env)
    outcome |= {
        "environment_steps_per_second": environment_rate(env),
        "preset": args.preset,
        "trainer": args.trainer,
        "metric": args.metric,
        "target": args.target,
        "devices": len(devices),
        "num_envs": env.num_envs,
        "frame_skip": env.task.frame_skip,
        "raw_physics_steps_per_second": raw,
        "fraction_of_raw_physics": outcome["train_steps_per_second"] * env.task.frame_skip / raw,
    }
    records = evaluated(resume, [when for when, _ in snapshots], evaluator.results)
    reached = next((entry for entry in records if entry[value_key] >= args.target), None)
    return outcome | {
        "snapshots": records,
        "reached_target_at_seconds": reached and reached["wall"],
        "reached_target_without_compile_seconds": reached and reached["wall"] - outcome["compile_seconds"],
        "reached_target_at_steps": reached and reached["step"],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", default="so_arm100_pick_place_mjx", help="a preset's name or a .pbtxt file")
    parser.add_argument("--trainer", choices=TRAINERS, default="ppo", help="the JAX trainer to time (default ppo)")
    parser.add_argument("--metric", choices=sorted(METRICS), default="success")
    parser.add_argument("--target", type=float, default=0.9, help="value of --metric to reach (default 0.9)")
    parser.add_argument("--max-seconds", type=float, default=900.0)
    parser.add_argument(
        "--stop-at",
        type=float,
        help="stop once the training value reaches this (default: --target for returns, never for success rates)",
    )
    parser.add_argument("--num-envs", type=int, help="override the preset's num_envs")
    parser.add_argument(
        "--iterations", type=int, help="stop after this many iterations (counted from the first run when resuming)"
    )
    # 1024: at a true success rate of 0.9, 128 episodes read 0.9 or more only about half the time (95 %: +-0.05),
    # so the first snapshot to read it was often a lucky one; 1024 read it within +-0.02. The rollout's steps
    # are sequential, so on a GPU more environments should add little to an evaluation's time (not yet measured).
    parser.add_argument("--eval-envs", type=int, default=1024, help="episodes of each deterministic evaluation")
    parser.add_argument("--snapshot-interval", type=int, default=20, help="snapshot every this many iterations")
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE", help="override a preset field")
    parser.add_argument(
        "--impl",
        choices=IMPLS,
        help="MJX's physics: jax or warp (MuJoCo Warp; training.mjx.impl, docs/training-mjx.md); default: the preset's",
    )
    parser.add_argument("--smoke", action="store_true", help="tiny sizes (CPU): 8 envs, 2 iterations, 4 episodes")
    parser.add_argument("--out", type=Path, required=True, help="folder for time_to_target.json and .png")
    parser.add_argument("--resume", type=Path, help="continue the run an earlier --out holds (its state/ and JSON)")
    parser.add_argument("--teacher-preset", help="train a teacher with this preset first (training.ppo.teacher)")
    parser.add_argument(
        "--teacher-steps",
        type=int,
        default=160_000_000,  # 70 M left one pick-and-place seed's teacher, and its pixel student, short of grasping
        help="the teacher's env steps",
    )
    args = parser.parse_args()
    if args.smoke:
        args.iterations, args.eval_envs, args.snapshot_interval = args.iterations or 2, 4, 1
    teacher_seconds = train_teacher(args) if args.teacher_preset else None
    outcome = run(args)
    if teacher_seconds is not None:
        reached = outcome["reached_target_at_seconds"]
        outcome |= {
            "teacher_seconds": teacher_seconds,
            "reached_target_with_teacher_seconds": reached and reached + teacher_seconds,
        }
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(args.out / "time_to_target.json", json_safe(outcome))
    title = f"{args.preset}: {args.trainer} on MJX, {outcome['num_envs']} envs, {outcome['devices']} device(s)"
    curve = plot_curve(outcome["snapshots"], args.metric, args.target, title)
    atomic_write_bytes(args.out / "time_to_target.png", curve)
    print("\n".join(summary_lines(outcome, args.metric, args.target)))
    if teacher_seconds is not None:
        reached = outcome["reached_target_with_teacher_seconds"]
        when = f"{args.metric} >= {args.target:g} at {reached:.1f} s with it" if reached else "target not reached"
        print(f"teacher {args.teacher_preset}: {teacher_seconds:.1f} s; {when}")
    print(f"wrote {args.out / 'time_to_target.json'} and {args.out / 'time_to_target.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(reported(main))  # a bad preset or --set is one line and exit 2, as in the CLI
