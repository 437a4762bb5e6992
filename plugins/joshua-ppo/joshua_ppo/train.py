"""`train_ppo`: PPO in JAX/Flax/Optax on a functional batched environment (EnvKind.JAX, e.g. `joshua_mjx.MjxEnv`).

The whole algorithm: settings in four groups (`joshua_ppo.settings`), a seed, and callbacks for
progress and checkpoints. Each iteration is one compiled function (`joshua_ppo.iteration`); this
loop only redraws the episodes' starts, checks the losses stay finite and reports. The trainer plugin
(`joshua_ppo.trainer`) adds configs, run folders and monitoring.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import jax
import jax.numpy as jnp

from joshua_core.errors import ConfigError, TrainingDiverged
from joshua_core.tasks import check_blow_ups
from joshua_ppo.envs import JaxEnv
from joshua_ppo.iteration import FAILED, make_iteration
from joshua_ppo.settings import NetworkSettings, OptimizationSettings, ReturnSettings, RolloutSettings
from joshua_ppo.state import Progress, TrainingState, abstract_state, init_state
from joshua_ppo.teacher import Teacher


@dataclass
class IterationReport:
    """What one iteration did: counters, timing, and its metrics as Python floats.

    metrics: `mean_return` and `mean_length` of the episodes that ended in this iteration
    (`episodes` of them; NaN when none), `reward/<term>` episode sums, `metrics/<name>` on the
    episodes' last steps, and the losses (`loss`, `policy_loss`, `value_loss`, `entropy`,
    `approx_kl`, `clip_fraction`, `action_std`, the policy's mean standard deviation, and
    `learning_rate`, the mean over the iteration's gradient steps; with `max_kl`, `kl_stopped`, the share
    of them it skipped).
    """

    iteration: int
    env_steps: int
    total_steps: int
    iteration_seconds: float
    steps_per_second: float
    wall_seconds: float  # since train_ppo was called
    compile_seconds: float  # before the first iteration: environments reset and the iteration compiled, at once
    metrics: dict[str, float] = field(default_factory=dict)


ProgressCallback = Callable[[IterationReport, Any], None]  # the report and the trainer's state
CheckpointCallback = Callable[[Any, Progress, IterationReport | None], None]


def train_ppo(
    env: JaxEnv,
    *,
    rollout: RolloutSettings,
    optimization: OptimizationSettings,
    returns: ReturnSettings,
    network: NetworkSettings,
    total_timesteps: int,
    seed: int = 0,
    checkpoint_interval: int = 0,
    resume: tuple[TrainingState, Progress] | None = None,
    on_progress: ProgressCallback | None = None,
    on_checkpoint: CheckpointCallback | None = None,
    should_stop: Callable[[], bool] | None = None,
    teacher: Teacher | None = None,
) -> tuple[TrainingState, Progress]:
    """Train until `total_timesteps` environment steps (rounded up to whole iterations).

    `on_progress` gets a report after every iteration; `on_checkpoint` gets the state every
    `checkpoint_interval` environment steps (0: never), before the first iteration of a new run
    (the untrained policy) and at the end. `resume` continues from a saved state and its counters.
    `should_stop` is asked after every iteration: True ends training there, with a checkpoint (Ctrl-C).
    `teacher`: a trained policy the policy imitates beside its PPO loss (`joshua_ppo.teacher`).
    Raises TrainingDiverged, without calling `on_checkpoint`, when a loss or parameter stops being finite.
    """
    started = time.perf_counter()
    iteration = make_iteration(
        env, rollout=rollout, optimization=optimization, returns=returns, network=network, teacher=teacher
    )
    abstract = abstract_state(env, network=network, optimization=optimization)
    return run_iterations(
        env,
        iteration,
        abstract,
        lambda: init_state(env, seed=seed, network=network, optimization=optimization),
        steps_per_iteration=env.num_envs * rollout.num_steps * rollout.unrolls_per_iteration,
        total_timesteps=total_timesteps,
        checkpoint_interval=checkpoint_interval,
        resume=resume,
        on_progress=on_progress,
        on_checkpoint=on_checkpoint,
        should_stop=should_stop,
        started=started,
    )


def run_iterations(
    env: JaxEnv,
    iteration: Callable[[Any], tuple[Any, dict[str, jax.Array]]],
    abstract: Any,
    init: Callable[[], Any],
    *,
    steps_per_iteration: int,
    total_timesteps: int,
    checkpoint_interval: int = 0,
    resume: tuple[Any, Progress] | None = None,
    on_progress: ProgressCallback | None = None,
    on_checkpoint: CheckpointCallback | None = None,
    should_stop: Callable[[], bool] | None = None,
    started: float | None = None,
) -> tuple[Any, Progress]:
    """The training loop every JAX trainer shares: compile `iteration` (a jitted state -> (state, metrics) of
    `steps_per_iteration` environment steps) for states like `abstract` while `init` makes the first state (unless
    resuming), then run it until `total_timesteps`, reporting and checkpointing as `train_ppo` says. `started`:
    when the caller began (perf_counter), so that the reported compile time includes its tracing."""
    if resume is not None and resume[0].env_state.observation.shape[0] != env.num_envs:
        raise ConfigError(
            f"the saved state has {resume[0].env_state.observation.shape[0]} environments, not {env.num_envs}"
        )
    started = time.perf_counter() if started is None else started
    # the iteration compiles while the environments reset (which compiles mjx.forward): both take seconds
    # of XLA compilation, which runs without holding the GIL. It is traced here, before the reset traces: traced
    # at once on two threads, the two programs came out different from run to run (JAX's tracing caches are
    # shared), so the persistent compilation cache never found them again.
    lowered = iteration.lower(abstract)
    with ThreadPoolExecutor(max_workers=1) as pool:
        compiling = pool.submit(lowered.compile)
        state, progress = resume or (init(), Progress(0, 0))
        compiled = compiling.result()
    compile_seconds = time.perf_counter() - started
    iterations = max(0, math.ceil((total_timesteps - progress.env_steps) / steps_per_iteration))
    total_steps = progress.env_steps + iterations * steps_per_iteration
    if resume is None and on_checkpoint is not None:
        on_checkpoint(state, progress, None)
    next_checkpoint = progress.env_steps + checkpoint_interval if checkpoint_interval > 0 else None
    # one iteration ahead: the next is queued (taking its input's buffers) before this one's metrics are read, so the
    # device need not wait while the host reports; the last interval reads short, its iteration queued before it began
    pending = _queue(env, compiled, state) if iterations else None
    last_read = time.perf_counter()
    try:
        for number in range(iterations):
            state, metrics = pending  # the previous state is let go before the next iteration's outputs are made
            if number + 1 < iterations:  # the next iteration takes this state's buffers: the callbacks get a copy
                state, pending = _copy(state), _queue(env, compiled, state)  # the copy is queued first
            values = {name: float(value) for name, value in jax.device_get(metrics).items()}
            _check_finite(values, progress)
            check_blow_ups(values["episodes"], values[FAILED], f"iteration {progress.iteration + 1}")
            read = time.perf_counter()
            elapsed, last_read = read - last_read, read
            progress = Progress(progress.iteration + 1, progress.env_steps + steps_per_iteration)
            report = IterationReport(
                iteration=progress.iteration,
                env_steps=progress.env_steps,
                total_steps=total_steps,
                iteration_seconds=elapsed,
                steps_per_second=steps_per_iteration / elapsed,
                wall_seconds=time.perf_counter() - started,
                compile_seconds=compile_seconds,
                metrics=values,
            )
            if on_progress is not None:
                on_progress(report, state)
            due = next_checkpoint is not None and progress.env_steps >= next_checkpoint
            stopping = should_stop is not None and should_stop()
            if on_checkpoint is not None and (due or stopping or progress.env_steps >= total_steps):
                on_checkpoint(state, progress, report)
                while next_checkpoint is not None and next_checkpoint <= progress.env_steps:
                    next_checkpoint += checkpoint_interval
            if stopping:
                break
    finally:
        _finish(pending)
    return state, progress


# new device buffers with the same values: an iteration given its input's buffers (donated) runs without a copy
_copy = jax.jit(lambda state: jax.tree.map(jnp.copy, state))


def _queue(env: JaxEnv, compiled: Callable, state: Any) -> tuple[Any, dict[str, jax.Array]]:
    """Queue an iteration from `state` (whose buffers it takes) on the device; every iteration's episodes start
    from fresh draws of the task's reset terms."""
    return compiled(state._replace(env_state=env.redraw_starts(state.env_state)))


def _finish(queued: tuple[Any, dict[str, jax.Array]] | None) -> None:
    """Wait for an iteration still queued when training ends early (a stop, an error), discarding its results and
    any error it meets: no computation outlives training. A MuJoCo Warp step runs Python callbacks on XLA's threads;
    one still queued when the interpreter finalized could never take the interpreter lock, and the process hung at
    exit (a Ctrl-C while the web page watched a Warp training on the CPU)."""
    if queued is not None:
        with contextlib.suppress(Exception):
            jax.block_until_ready(queued)


def _check_finite(values: dict[str, float], progress: Progress) -> None:
    """Raise TrainingDiverged when an iteration's losses or parameters stopped being finite (pops params_finite)."""
    finite = values.pop("params_finite") == 1.0
    bad = [name for name in ("loss", "policy_loss", "value_loss") if not math.isfinite(values[name])]
    if bad or not finite:
        what = f"{', '.join(bad)} became {values[bad[0]]}" if bad else "the network parameters became non-finite"
        raise TrainingDiverged(
            f"training diverged in iteration {progress.iteration + 1} ({progress.env_steps} steps done): {what}; "
            "the last checkpoint written before it is kept. Lower training.learning_rate, set the trainer's "
            "max_grad_norm, or check the task's rewards and observations for huge values"
        )
