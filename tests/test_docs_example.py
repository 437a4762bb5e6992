"""The worked plugin example of docs/writing-plugins.md (docs/examples/joshua-rk4) builds, installs and works."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = REPO_ROOT / "docs" / "examples" / "joshua-rk4"

# A pendulum: its motion depends on the integrator, so RK4 and the default give different states.
PENDULUM = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body>
      <joint name="hinge" type="hinge" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.02" mass="1"/>
    </body>
  </worldbody>
  <keyframe><key name="out" qpos="1"/></keyframe>
</mujoco>
"""

# A config using the example's mode and its typed options (simulation.rk4_compare, field 10000).
COMPARE_CONFIG = """\
operation_mode: SIMULATION
simulation {
  mode: RK4_COMPARE
  model_path: "pendulum.xml"
  keyframe: "out"
  rk4_compare { steps: 200 report_name: "compare.json" }
}
"""

# Runs with the example installed: discovery and options stay light, then the backend's engines step with RK4.
PROBE = """
import json, sys
from pathlib import Path
import joshua_rk4
from joshua_core.plugins import PluginHost
from joshua_core.kinds import Kind

host = PluginHost.discover()
component = host.component(Kind.BACKEND, "mujoco_rk4")
host.options()  # imports every registered options module, joshua_rk4.options_pb2 too
light = "mujoco" not in sys.modules
engine = host.backend("mujoco_rk4").create_engine(Path(sys.argv[1]), host)

import mujoco

def run_raw(integrator):
    model = mujoco.MjModel.from_xml_path(sys.argv[1])
    if integrator is not None:
        model.opt.integrator = integrator
    data = mujoco.MjData(model)
    data.qpos[0] = 1.0
    mujoco.mj_step(model, data, 200)
    return data.qpos.tolist()

engine.data.qpos[0] = 1.0
engine.step(200)
print(json.dumps({
    "package": joshua_rk4.__file__,
    "distribution": component.plugin.distribution,
    "target": component.target,
    "light": light,
    "integrator": int(engine.model.opt.integrator),
    "rk4": int(mujoco.mjtIntegrator.mjINT_RK4),
    "engine_qpos": engine.get_qpos().tolist(),
    "raw_rk4_qpos": run_raw(mujoco.mjtIntegrator.mjINT_RK4),
    "raw_default_qpos": run_raw(None),
}))
"""


def with_site(site: Path) -> dict[str, str]:
    """The environment that makes the installed example importable, ahead of any PYTHONPATH already set."""
    return {"PYTHONPATH": os.pathsep.join(filter(None, [str(site), os.environ.get("PYTHONPATH")]))}


@pytest.fixture(scope="module")
def example_site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The example built into a wheel and installed into its own folder, as a user's pip would."""
    root = tmp_path_factory.mktemp("joshua_rk4")
    wheels, site = root / "wheels", root / "site"
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    subprocess.run([*pip, "wheel", "--no-deps", "--no-build-isolation", "-w", str(wheels), str(EXAMPLE)], check=True)
    built = sorted(wheels.glob("joshua_rk4-*.whl"))
    assert len(built) == 1, built
    subprocess.run([*pip, "install", "--no-deps", "--target", str(site), str(built[0])], check=True)
    return site


def test_plugins_lists_the_rk4_backend_mode_and_options(example_site: Path, run_joshua) -> None:
    result = run_joshua("plugins", env=with_site(example_site))
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("rk4  (joshua-rk4 "))
    assert lines[header].endswith("joshua_rk4.plugin") and "[BROKEN]" not in lines[header]
    registered = [line.split()[:2] for line in lines[header + 1 : header + 4]]
    assert registered == [["backend", "mujoco_rk4"], ["mode", "RK4_COMPARE"], ["option", "rk4_compare"]]
    assert "conflict" not in result.stdout


def test_a_run_on_the_rk4_backend_succeeds(example_site: Path, run_joshua, tmp_path: Path) -> None:
    result = run_joshua(
        "--set",
        "simulation.mode=HEADLESS",
        "--set",
        "simulation.backend=mujoco_rk4",
        "--set",
        "simulation.duration=0.2",
        env=with_site(example_site),
    )
    assert result.returncode == 0, result.stderr
    assert "warning" not in result.stderr
    summary = json.loads((tmp_path / "joshua_output" / "headless_summary.json").read_text())
    assert summary["sim_seconds"] >= 0.2 and summary["steps"] > 0


def test_the_backend_creates_engines_that_step_with_rk4(example_site: Path, tmp_path: Path) -> None:
    model = tmp_path / "pendulum.xml"
    model.write_text(textwrap.dedent(PENDULUM))
    probe = subprocess.run(
        [sys.executable, "-c", PROBE, str(model)],
        cwd=tmp_path,
        env={**os.environ, **with_site(example_site)},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert probe.returncode == 0, probe.stderr
    report = json.loads(probe.stdout)
    assert report["package"].startswith(str(example_site))  # the built wheel, not the source folder
    assert report["distribution"] == "joshua-rk4"
    assert report["target"] == "joshua_rk4.backend:RK4Backend"
    assert report["light"], "discovering the plugin imported mujoco"
    assert report["integrator"] == report["rk4"]
    assert report["engine_qpos"] == report["raw_rk4_qpos"]
    assert report["engine_qpos"] != pytest.approx(report["raw_default_qpos"], abs=1e-9)


def test_the_compare_mode_runs_with_its_own_options(example_site: Path, run_joshua, tmp_path: Path) -> None:
    (tmp_path / "pendulum.xml").write_text(textwrap.dedent(PENDULUM))
    config = tmp_path / "compare.pbtxt"
    config.write_text(COMPARE_CONFIG)
    env = with_site(example_site)
    result = run_joshua("--config", str(config), env=env)
    assert result.returncode == 0, result.stderr
    report = json.loads((tmp_path / "joshua_output" / "compare.json").read_text())
    assert (report["steps"], report["integrator"], report["tolerance"]) == (200, "EULER", 0.0)
    assert 1e-4 < report["max_divergence"] < 1.0 and report["final_divergence"] <= report["max_divergence"]

    over = run_joshua("--config", str(config), "--set", "simulation.rk4_compare.tolerance=1e-9", env=env)
    assert over.returncode == 1 and "over the tolerance 1e-09" in over.stderr

    printed = run_joshua("--config", str(config), "--set", "simulation.rk4_compare.steps=50", "--print-config", env=env)
    assert printed.returncode == 0, printed.stderr
    assert "  mode: RK4_COMPARE\n" in printed.stdout
    assert '  rk4_compare {\n    steps: 50\n    report_name: "compare.json"\n  }\n' in printed.stdout

    config.write_text(COMPARE_CONFIG.replace("steps: 200", "step: 200"))
    error = run_joshua("--config", str(config), env=env)
    assert error.returncode == 2 and "Traceback" not in error.stderr
    assert f'{config}:6:17: CompareOptions has no field or option named "step". Did you mean: steps?' in error.stderr


def test_the_third_party_trainer_reuses_what_the_core_and_backend_offer(tmp_path: Path) -> None:
    """docs/examples/random_trainer (docs/writing-plugins.md, "Adding a backend or trainer"), registered like any
    plugin's trainer, trains on the mujoco backend's environments: desynchronised episodes end and are counted
    by the backend, and its run folder and checkpoint are the core's."""
    from joshua_core import builtin_plugin, hookimpl
    from joshua_core.config_pb2 import TrainingConfig
    from joshua_core.plugins import PluginHost, PluginInfo
    from joshua_core.resources import resolve_data_path
    from joshua_core.run_context import RunContext
    from joshua_core.runs import CONFIG_FILE, list_runs
    from joshua_tasks import TASKS

    sys.path.insert(0, str(REPO_ROOT / "docs" / "examples" / "random_trainer"))
    try:
        import random_trainer
    finally:
        sys.path.pop(0)

    class RandomPlugin:
        @hookimpl
        def joshua_register_trainers(self, registry) -> None:
            registry.add("random", random_trainer.RandomTrainer, "random actions", env_kinds=("numpy",))

    import joshua_mujoco.plugin
    import joshua_tasks.plugin

    host = PluginHost(
        [
            (PluginInfo("core", "joshua-core", "0", "core"), builtin_plugin),
            (PluginInfo("mujoco", "joshua-mujoco", "0", "joshua_mujoco.plugin"), joshua_mujoco.plugin),
            (PluginInfo("tasks", "joshua-tasks", "0", "joshua_tasks.plugin"), joshua_tasks.plugin),
            (PluginInfo("random", "joshua-random", "0", "random_trainer"), RandomPlugin()),
        ]
    )
    spec = TASKS["so_arm100_reach"]
    training = TrainingConfig(
        trainer="random",
        backend="mujoco",
        task=spec.name,
        model_path=str(resolve_data_path(spec.model_path)),
        num_envs=4,
        total_timesteps=4 * spec.episode_length,  # each environment's first (desynchronised) episode ends in it
        seed=3,
    )
    checkpoint = host.trainer("random").train(training, RunContext(host, tmp_path))

    (run,) = list_runs(tmp_path)
    assert json.loads((run / CONFIG_FILE).read_text())["trainer"] == "random"
    assert checkpoint.name == f"{run.name}_step_{training.total_timesteps}"
    summary = json.loads((checkpoint / "returns.json").read_text())
    assert summary["episodes"] >= training.num_envs, summary
    assert isinstance(summary["mean_return"], float)
