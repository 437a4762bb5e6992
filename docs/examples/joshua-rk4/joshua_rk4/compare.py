"""The `RK4_COMPARE` mode: how far the model's own integrator drifts from RK4, as a JSON report.

It runs the model twice from the same start (the config's keyframe, or the model's initial state):
once with the integrator the model file names, once with RK4 (the `mujoco_rk4` backend's engine),
and records the largest joint position difference at any step. Its settings are the plugin's own
typed options, `simulation.rk4_compare` (joshua_rk4/options.proto), read with `options_of`.
Imported only when a run uses the mode, so importing mujoco here is fine.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from joshua_core.atomic import atomic_write_json
from joshua_core.config_pb2 import SimulationConfig
from joshua_core.errors import ConfigError, JoshuaError
from joshua_core.interfaces import Mode
from joshua_core.options import options_of
from joshua_core.run_context import RunContext
from joshua_mujoco import MuJoCoEngine
from joshua_rk4 import options_pb2
from joshua_rk4.backend import RK4Backend

DEFAULT_STEPS = 500
DEFAULT_REPORT_NAME = "rk4_compare.json"


class CompareMode(Mode):
    """Steps the model with its own integrator and with RK4 side by side and reports their divergence."""

    def run(self, config: SimulationConfig, context: RunContext) -> None:
        options = options_of(config, options_pb2.rk4_compare)
        if options.steps < 0 or options.tolerance < 0:
            raise ConfigError("simulation.rk4_compare.steps and .tolerance must not be negative")
        steps = options.steps or DEFAULT_STEPS
        model_path = Path(config.model_path)
        with (
            MuJoCoEngine(model_path, plugins=context.plugins) as own,
            RK4Backend().create_engine(model_path, context.plugins) as rk4,
        ):
            for engine in (own, rk4):
                try:
                    engine.reset(config.keyframe or None)
                except KeyError as error:
                    raise ConfigError(f"simulation.keyframe: {error.args[0]}") from None
            report = {
                "model_path": config.model_path,
                "steps": steps,
                "timestep": own.timestep,
                "integrator": mujoco.mjtIntegrator(own.model.opt.integrator).name.removeprefix("mjINT_"),
                **_divergence(own, rk4, steps),
                "tolerance": options.tolerance,
            }
        path = context.output_dir / (options.report_name or DEFAULT_REPORT_NAME)
        atomic_write_json(path, report)
        largest = report["max_divergence"]
        print(f"{report['integrator']} vs RK4, {steps} steps: largest joint difference {largest:.3e}; report: {path}")
        if options.tolerance and largest > options.tolerance:
            raise JoshuaError(f"the integrators diverge by {largest:.3e}, over the tolerance {options.tolerance:g}")


def _divergence(own: MuJoCoEngine, rk4: MuJoCoEngine, steps: int) -> dict[str, float]:
    """Step both engines `steps` times; the largest and the final max-abs joint position difference."""
    largest = 0.0
    for _ in range(steps):
        own.step()
        rk4.step()
        largest = max(largest, float(np.max(np.abs(own.get_qpos() - rk4.get_qpos()), initial=0.0)))
    final = float(np.max(np.abs(own.get_qpos() - rk4.get_qpos()), initial=0.0))
    return {"max_divergence": largest, "final_divergence": final}
