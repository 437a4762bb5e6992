"""HEADLESS mode: step a model with no rendering, as a smoke test of the model and a speed check.

The actuators hold the start keyframe's controls. Every simulated second the state is checked to be
finite; a divergence stops the run with the time it happened. A summary (steps, simulated and wall
seconds, real-time factor, largest joint drift) is printed and written to `headless_summary.json`.
"""

from __future__ import annotations

import math
import sys
import time
from typing import Any

import numpy as np

from joshua_core.atomic import atomic_write_json, json_safe
from joshua_core.config_pb2 import SimulationConfig
from joshua_core.errors import JoshuaError
from joshua_core.interfaces import Engine, Mode
from joshua_core.progress import progress_bar
from joshua_core.run_context import RunContext

DEFAULT_DURATION_S = 5.0
SUMMARY_FILE = "headless_summary.json"


class HeadlessMode(Mode):
    """Runs `duration` simulated seconds as fast as possible and reports how it went."""

    def run(self, config: SimulationConfig, context: RunContext) -> None:
        warn_no_web_page(config, "HEADLESS")
        with context.create_engine(config) as engine:
            summary = simulate(engine, config.duration or DEFAULT_DURATION_S)
        summary["model_path"] = config.model_path
        summary["keyframe"] = config.keyframe
        path = context.output_dir / SUMMARY_FILE
        atomic_write_json(path, json_safe(summary))  # a zero wall time makes the rates inf: null
        print(
            f"simulated {summary['sim_seconds']:.2f} s in {summary['wall_seconds']:.2f} s "
            f"({summary['realtime_factor']:.1f}x real time, {summary['steps_per_second']:.0f} steps/s); "
            f"largest joint drift {summary['max_qpos_drift']:.2e}; summary: {path}"
        )


def warn_no_web_page(config: SimulationConfig, mode: str) -> None:
    """One line when `simulation.web` (`--web`) is set for `mode`, which shows no page: it would be ignored unsaid."""
    if config.web:
        print(f"joshua: warning: {mode} mode has no web page; ignored simulation.web ({config.web})", file=sys.stderr)


def simulate(engine: Engine, duration: float) -> dict[str, Any]:
    """Step `engine` for `duration` simulated seconds, one-second chunks, checking finiteness each chunk."""
    total_steps = max(1, math.ceil(duration / engine.timestep))
    chunk = max(1, round(1.0 / engine.timestep))
    start_qpos = engine.get_qpos()
    max_drift = 0.0
    done = 0
    started = time.perf_counter()
    with progress_bar(total_steps * engine.timestep, description="headless", unit="sim s") as bar:
        while done < total_steps:
            n = min(chunk, total_steps - done)
            engine.step(n)
            done += n
            qpos = engine.get_qpos()
            problem = engine.instability() or (None if np.all(np.isfinite(qpos)) else "non-finite qpos")
            if problem:
                raise JoshuaError(f"simulation diverged by t = {done * engine.timestep:.3f} s: {problem}")
            max_drift = max(max_drift, float(np.max(np.abs(qpos - start_qpos), initial=0.0)))
            bar.update(n * engine.timestep)
    wall = time.perf_counter() - started
    sim_seconds = done * engine.timestep
    return {
        "steps": done,
        "sim_seconds": sim_seconds,
        "wall_seconds": wall,
        "realtime_factor": sim_seconds / wall if wall > 0 else math.inf,
        "steps_per_second": done / wall if wall > 0 else math.inf,
        "max_qpos_drift": max_drift,
    }
