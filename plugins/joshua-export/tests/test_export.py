"""`joshua export` end to end: tiny PPO (Flax) and SB3 (torch) runs of so_arm100_reach are exported, the ONNX file
is checked by onnx and run by onnxruntime, and its actions equal each trainer's own deterministic actions on 1000
random observations; the contract's slices tile the task's observation; bad runs are one line, exit 2."""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace

import mujoco
import numpy as np
import onnx
import onnxruntime
import pytest

from joshua_core.errors import UsageError
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_export import load_policy
from joshua_mujoco import load_task_model

JOSHUA = [sys.executable, "-m", "joshua_core.cli"]
SAMPLES = 1000
TOLERANCE = 1e-5
PPO_TINY = {  # 4 environments x 5 steps, one iteration: enough for a normaliser and weights that moved; MuJoCo
    # Warp's physics (the export reads only the network), whose iteration compiles far sooner than MJX-JAX's
    "task": "so_arm100_reach", "num_envs": 4, "num_steps": 5, "minibatch_size": 20, "num_epochs": 1,
    "mjx": {"impl": "WARP"},
    "total_timesteps": 20, "run_name": "tiny", "hidden_sizes": [32, 16], "ppo": {"video_interval": -1},
}  # fmt: skip


def joshua(*args: str, cwd: Path, key: Path | None = None) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, **({"JOSHUA_CHECKPOINT_KEY_FILE": str(key)} if key else {})}
    return subprocess.run([*JOSHUA, *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


def one_line_exit_2(done: subprocess.CompletedProcess[str], message: str) -> None:
    assert done.returncode == 2, (done.returncode, done.stderr[-2000:])
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], done.stderr


def random_observations(contract: dict, seed: int = 0) -> np.ndarray:
    """Observations around the normaliser's statistics (3 standard deviations: some are clipped)."""
    normalization = contract["observation"]["normalization"]
    mean, std = np.array(normalization["mean"]), np.array(normalization["std"])
    noise = np.random.default_rng(seed).normal(size=(SAMPLES, len(mean)))
    return (mean + 3.0 * std * noise).astype(np.float32)


def run_onnx(folder: Path, observations: np.ndarray) -> np.ndarray:
    """The actions of the exported graph, checked by onnx and run by a plain onnxruntime session."""
    model = onnx.load(folder / "policy.onnx")
    onnx.checker.check_model(model, full_check=True)
    session = onnxruntime.InferenceSession(str(folder / "policy.onnx"), providers=["CPUExecutionProvider"])
    contract = json.loads((folder / "policy.json").read_text())
    (inputs,), (outputs,) = contract["onnx"]["inputs"], contract["onnx"]["outputs"]
    assert [session.get_inputs()[0].name, session.get_outputs()[0].name] == [inputs["name"], outputs["name"]]
    assert session.get_inputs()[0].shape == inputs["shape"] and session.get_outputs()[0].shape == outputs["shape"]
    (actions,) = session.run([outputs["name"]], {inputs["name"]: observations})
    return actions


def check_contract(contract: dict, task: str, trainer: str, model_path: str) -> None:
    """The contract's terms tile the observation the task builds; rate and actions are the task's."""
    built, model = load_task_model(task, resolve_data_path(model_path), PluginHost.discover(), None)
    terms = contract["observation"]["terms"]
    assert [term["name"] for term in terms] == [term.name for term in built.observation_terms]
    assert terms[0]["start"] == 0 and all(a["stop"] == b["start"] for a, b in zip(terms, terms[1:], strict=False))
    assert terms[-1]["stop"] == contract["observation"]["size"] == built.observation_size
    assert contract["control_hz"] == pytest.approx(1.0 / (model.opt.timestep * built.frame_skip)) == 50.0
    assert [t["actuator"] for t in contract["action"]["terms"]] == [model.actuator(i).name for i in range(model.nu)]
    assert contract["task"] == task and contract["trainer"] == trainer and contract["model"]["file"] == "policy.onnx"
    assert contract["robot"]["model_path"] == model_path  # a shipped model stays relative: any checkout finds it


@pytest.fixture(scope="module")
def sb3_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A 3200-step SB3 PPO run of the shipped reach preset: (run folder, checkpoint key)."""
    work = tmp_path_factory.mktemp("sb3")
    key = work / "checkpoint.key"
    done = joshua(
        "--preset", "so_arm100_reach_sb3", "--set", "training.total_timesteps=3200",
        "--set", "training.checkpoint_dir=runs", "--set", "training.run_name=reach", cwd=work, key=key,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    return work / "runs" / "reach", key


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from joshua_ppo import train_mjx

    root = tmp_path_factory.mktemp("ppo")
    checkpoint = train_mjx(model_path="so_arm100/scene_mjx.xml", config=PPO_TINY, checkpoint_dir=root)
    assert checkpoint == root / "tiny_step_20"
    return root / "tiny"


def test_sb3_policy_exports_to_onnx_with_the_same_actions(sb3_run: tuple[Path, Path], tmp_path: Path) -> None:
    from stable_baselines3 import PPO

    run, key = sb3_run
    out = tmp_path / "exported"
    done = joshua("export", str(run), "--out", str(out), cwd=tmp_path, key=key)
    assert done.returncode == 0, done.stderr[-2000:]
    checkpoint = run.parent / "reach_step_3200"
    policy, contract = load_policy(out)
    check_contract(contract, "so_arm100_reach", "sb3", "so_arm100/scene.xml")
    observations = random_observations(contract)
    with (checkpoint / "vecnormalize.pkl").open("rb") as handle:
        normalizer = pickle.load(handle)  # written by this test's run
    expected, _ = PPO.load(checkpoint / "model.zip", device="cpu").predict(
        normalizer.normalize_obs(observations), deterministic=True
    )
    assert np.abs(expected).max() > 0.01  # a policy whose actions are not all zero
    assert np.abs(run_onnx(out, observations) - expected).max() < TOLERANCE
    assert np.abs(policy(observations) - expected).max() < TOLERANCE
    assert np.abs(policy(observations[0]) - expected[0]).max() < TOLERANCE


@pytest.mark.slow
def test_ppo_policy_exports_into_its_checkpoint_with_the_same_actions(ppo_run: Path) -> None:
    from flax.serialization import from_bytes

    from joshua_ppo.normalizer import RunningStatistics
    from joshua_ppo.policy import make_network, policy_actions
    from joshua_ppo.settings import NetworkSettings

    done = joshua("export", str(ppo_run), cwd=ppo_run.parent)
    assert done.returncode == 0, done.stderr[-2000:]
    checkpoint = ppo_run.parent / "tiny_step_20"
    _, contract = load_policy(checkpoint)
    check_contract(contract, "so_arm100_reach", "ppo", "so_arm100/scene_mjx.xml")
    saved = from_bytes(None, (checkpoint / "params.msgpack").read_bytes())
    network = NetworkSettings(hidden_sizes=(32, 16))
    net = make_network(SimpleNamespace(action_size=6), network)
    observations = random_observations(contract, seed=1)
    statistics = RunningStatistics(**saved["normalizer"])
    expected = np.clip(np.asarray(policy_actions(net, saved["params"], statistics, observations, network)), -1, 1)
    assert np.abs(expected).max() > 0.01
    assert np.abs(run_onnx(checkpoint, observations) - expected).max() < TOLERANCE


@pytest.mark.slow
def test_bad_runs_are_one_line_exit_2(sb3_run: tuple[Path, Path], ppo_run: Path, tmp_path: Path) -> None:
    run, key = sb3_run
    one_line_exit_2(joshua("export", str(tmp_path / "nothing"), cwd=tmp_path, key=key), "does not exist")
    copy = tmp_path / "copy_step_3200"
    shutil.copytree(run.parent / "reach_step_3200", copy)
    config = json.loads((copy / "config.json").read_text())
    (copy / "config.json").write_text(json.dumps({**config, "trainer": "sb4"}))
    one_line_exit_2(joshua("export", str(copy), cwd=tmp_path, key=key), "no trainer named 'sb4'")
    del config["training"]["task"]
    (copy / "config.json").write_text(json.dumps(config))
    one_line_exit_2(  # an edited config.json fails the signature check unless the user trusts the checkpoint
        joshua("export", str(copy), "--trust-checkpoint", cwd=tmp_path, key=key), "names no task"
    )
    one_line_exit_2(joshua("export", str(copy), cwd=tmp_path, key=tmp_path / "other.key"), "refusing to load")
    damaged = tmp_path / "tiny_step_20"
    shutil.copytree(ppo_run.parent / "tiny_step_20", damaged)
    (damaged / "params.msgpack").write_bytes((damaged / "params.msgpack").read_bytes()[:100])
    one_line_exit_2(joshua("export", str(damaged), cwd=tmp_path), "cannot load")
    (damaged / "params.msgpack").unlink()
    one_line_exit_2(joshua("export", str(damaged), cwd=tmp_path), "has no params.msgpack")


@pytest.mark.slow
def test_out_replaces_only_a_folder_joshua_wrote_and_only_with_overwrite(
    sb3_run: tuple[Path, Path], tmp_path: Path
) -> None:
    run, key = sb3_run  # the lighter of the two runs: --out is the same for every trainer
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    for extra in ((), ("--overwrite",)):
        one_line_exit_2(
            joshua("export", str(run), "--out", "mine", *extra, cwd=tmp_path, key=key), "not written by joshua"
        )
        one_line_exit_2(joshua("export", str(run), "--out", ".", *extra, cwd=tmp_path, key=key), "no folder of its own")
    assert (mine / "notes.txt").read_text() == "keep"
    done = joshua("export", str(run), "--out", "out", cwd=tmp_path, key=key)
    assert done.returncode == 0, done.stderr[-2000:]
    one_line_exit_2(joshua("export", str(run), "--out", "out", cwd=tmp_path, key=key), "exists; pass --overwrite")
    (tmp_path / "out" / "policy.onnx").write_bytes(b"stale")
    done = joshua("export", str(run), "--out", "out", "--overwrite", cwd=tmp_path, key=key)
    assert done.returncode == 0, done.stderr[-2000:]
    load_policy(tmp_path / "out")  # whole again: the graph its contract names
    assert sorted(path.name for path in tmp_path.iterdir()) == ["mine", "out"]  # no temporaries left


def test_the_model_hash_does_not_depend_on_where_the_checkout_lies(tmp_path: Path) -> None:
    """The contract's robot hash holds across checkouts (MuJoCo keeps the meshes' absolute paths in the model),
    and still tells a changed model apart."""
    from joshua_export.observer import model_sha256

    models = Path(resolve_data_path("so_arm100/scene.xml")).parent
    shutil.copytree(models, tmp_path / "so_arm100")
    here = mujoco.MjModel.from_xml_path(str(models / "scene.xml"))
    elsewhere = mujoco.MjModel.from_xml_path(str(tmp_path / "so_arm100" / "scene.xml"))
    assert bytes(here.paths) != bytes(elsewhere.paths)
    assert model_sha256(here) == model_sha256(elsewhere)
    elsewhere.actuator_gainprm[0, 0] *= 1.01
    assert model_sha256(here) != model_sha256(elsewhere)


def garbage_with_its_hash(folder: Path) -> None:
    """A policy.onnx that is no graph, its contract updated to match: the hash passes, onnxruntime refuses it."""
    (folder / "policy.onnx").write_bytes(b"not a graph")
    contract = json.loads((folder / "policy.json").read_text())
    contract["model"]["sha256"] = hashlib.sha256(b"not a graph").hexdigest()
    (folder / "policy.json").write_text(json.dumps(contract))


def edited_model_entry(value: object) -> Callable[[Path], None]:
    def edit(folder: Path) -> None:
        contract = json.loads((folder / "policy.json").read_text())
        (folder / "policy.json").write_text(json.dumps(contract | {"model": value}))

    return edit


def deeply_nested_contract(folder: Path) -> None:
    """A policy.json that json.loads gives up on (it recurses once per level, past Python's limit)."""
    (folder / "policy.json").write_text("[" * 100_000 + "]" * 100_000)


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (garbage_with_its_hash, "policy.onnx: onnxruntime cannot load it as a policy: [ONNXRuntimeError]"),
        (edited_model_entry(None), "policy.json: model is None; expected the ONNX file's name and sha256"),
        (edited_model_entry({"file": 7, "sha256": ""}), "expected the ONNX file's name and sha256"),
        (edited_model_entry({"file": "../policy.onnx", "sha256": ""}), "model.file '../policy.onnx' holds a '/'"),
        (deeply_nested_contract, "policy.json: cannot read the policy's contract: nested too deeply"),
    ],
)
def test_a_damaged_exported_policy_is_one_line(tmp_path: Path, damage: Callable[[Path], None], message: str) -> None:
    folder = tmp_path / "policy"
    shutil.copytree(resolve_data_path("policies/so_arm100_reach", folders=True), folder)
    damage(folder)
    with pytest.raises(UsageError) as refused:
        load_policy(folder)
    assert message in str(refused.value) and "\n" not in str(refused.value), str(refused.value)
