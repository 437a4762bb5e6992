"""CPU PhysX against mujoco.batch: env steps/s of the Isaac Ant task on the usd backend, same cores, one run.

Also rolls the same open-loop controls on both engines from the same start and prints how far the joint
trajectories drift apart (sim-to-sim). Usage: python bench/physx_vs_mujoco.py [--envs 256] [--steps 200]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.interfaces import EnvKind, EnvSpec
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_mujoco.vector import task_config_from_options
from joshua_usd.options_pb2 import UsdOptions, usd

NO_RESET_NOISE = {"reset_joints_uniform": {"weight": 0}, "reset_qvel_normal": {"weight": 0}}


def make(plugins: PluginHost, physics: int, num_envs: int):  # type: ignore[no-untyped-def]
    training = TrainingConfig()
    training.Extensions[usd].physics = physics
    spec = EnvSpec(
        "isaac_ant_locomotion",
        num_envs,
        model_path=resolve_data_path("isaac/ant.usd"),
        task_config=task_config_from_options({"terms": NO_RESET_NOISE}),
        training=training,
    )
    return plugins.backend("usd").create_envs(spec, EnvKind.NUMPY, plugins)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--envs", type=int, default=256)
    parser.add_argument("--steps", type=int, default=200)
    args = parser.parse_args()
    plugins = PluginHost.discover()
    controls = np.sin(np.arange(args.steps)[:, None, None] * 0.2 + np.arange(8)) * np.ones((1, args.envs, 1))
    results = {}
    for name, physics in (("mujoco", UsdOptions.MUJOCO), ("physx", UsdOptions.PHYSX)):
        env = make(plugins, physics, args.envs)
        env.reset(seed=0)
        joints = []
        start = time.perf_counter()
        for action in controls:
            env.step(action)
            joints.append(env.qpos[0, 7:].copy())
        seconds = time.perf_counter() - start
        results[name] = np.array(joints)
        print(f"{name}: {args.envs * args.steps / seconds:.0f} env steps/s ({args.envs} envs, {args.steps} steps)")
        env.close()
    gap = np.abs(results["physx"] - results["mujoco"])
    for t in (9, 49, args.steps - 1):
        if t < args.steps:
            print(f"step {t + 1}: joint gap mean {gap[t].mean():.3f} rad, max {gap[t].max():.3f} rad")


if __name__ == "__main__":
    main()
