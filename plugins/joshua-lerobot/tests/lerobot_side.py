"""The real `lerobot` (0.4.4 on Python 3.11, 0.6 on 3.12), run in a subprocess by the tests (lerobot_harness.py) with
the pinned packages of this Python's lerobot-requirements file first on PYTHONPATH (so they never change the venv).
Prints one JSON document.

    python lerobot_side.py load ROOT      LeRobotDataset(root=ROOT): every frame's state, action, timestamp,
                                          episode, and each camera's decoded frames (shape, mean per frame)
    python lerobot_side.py delta ROOT     LeRobotDataset(root=ROOT, delta_timestamps=...): every frame with the state
                                          of the frame before, the actions of this and the next two frames, each
                                          camera's frame before and this one (decoded), and their padding masks
    python lerobot_side.py write ROOT     LeRobotDataset.create + add_frame + save_episode: two SO-100 episodes
                                          of known values with one camera; prints what it wrote
    python lerobot_side.py normalize FILE lerobot's `MotorsBus._normalize` of the SO-100 follower's motors, with
                                          FILE's calibration, on FILE's ticks: per motor, the values with
                                          use_degrees=True and with use_degrees=False
    python lerobot_side.py sac FILE       a small SAC actor (SACPolicy; GaussianActorPolicy from lerobot 0.6) with
                                          FILE's input features and action range, saved with its pre/post-processors
                                          (save_pretrained) in FILE's "out" folder

torchvision is not installed (on 3.11 its PyPI wheels are CUDA builds beside a CPU torch):
tests/no_torchvision/sitecustomize.py puts placeholders in its place whose use raises.
"""

from __future__ import annotations

import json
import sys
import types
from pathlib import Path
from typing import Any

import numpy as np

SO100_NAMES = [
    "shoulder_pan.pos",
    "shoulder_lift.pos",
    "elbow_flex.pos",
    "wrist_flex.pos",
    "wrist_roll.pos",
    "gripper.pos",
]
REPO_ID = "local/joshua_test"
FPS = 30
FRAMES_PER_EPISODE = (45, 30)
IMAGE_SHAPE = (48, 64, 3)


def known_state(episode: int, frame: int) -> np.ndarray:
    """The SO-100 state written for a frame: degrees for the arm (within +-90), 0..100 for the gripper."""
    t = frame / FPS
    arm = [40 * np.sin(t + joint + episode) for joint in range(5)]
    return np.array([*arm, 50 + 40 * np.sin(2 * t + episode)], dtype=np.float32)


def normalize(request: Path) -> dict[str, Any]:
    """What lerobot's motor bus reads for each of `request`'s ticks, as SOFollower builds its bus."""
    from lerobot.motors.feetech.tables import MODEL_RESOLUTION
    from lerobot.motors.motors_bus import Motor, MotorCalibration, MotorNormMode, MotorsBus

    spec = json.loads(request.read_text())
    calibration = {motor: MotorCalibration(**entry) for motor, entry in spec["calibration"].items()}
    answer: dict[str, Any] = {}
    for use_degrees in (True, False):
        body = MotorNormMode.DEGREES if use_degrees else MotorNormMode.RANGE_M100_100  # as SOFollower.__init__
        motors = {
            motor: Motor(entry.id, "sts3215", MotorNormMode.RANGE_0_100 if motor == "gripper" else body)
            for motor, entry in calibration.items()
        }
        bus = types.SimpleNamespace(
            calibration=calibration,
            motors=motors,
            apply_drive_mode=True,  # FeetechMotorsBus's
            model_resolution_table=MODEL_RESOLUTION,
            _id_to_name=lambda id_, motors=motors: next(name for name, m in motors.items() if m.id == id_),
            _id_to_model=lambda id_: "sts3215",
        )
        answer[str(use_degrees)] = {
            motor: [MotorsBus._normalize(bus, {entry.id: tick})[entry.id] for tick in spec["ticks"][motor]]
            for motor, entry in calibration.items()
        }
    return answer


def load(root: Path) -> dict[str, Any]:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    dataset = LeRobotDataset(REPO_ID, root=root)
    frames = [dataset[i] for i in range(len(dataset))]
    cameras = dataset.meta.video_keys
    return {
        "frames": len(dataset),
        "episodes": dataset.num_episodes,
        "fps": dataset.fps,
        "state": [frame["observation.state"].tolist() for frame in frames],
        "action": [frame["action"].tolist() for frame in frames],
        "timestamp": [float(frame["timestamp"]) for frame in frames],
        "episode_index": [int(frame["episode_index"]) for frame in frames],
        "task": [frame["task"] for frame in frames],
        "cameras": {
            key: {
                "shape": list(frames[0][key].shape),
                "mean": [float(frame[key].mean()) for frame in frames],  # in [0, 1], channels first
            }
            for key in cameras
        },
    }


def delta(root: Path) -> dict[str, Any]:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset, LeRobotDatasetMetadata

    meta = LeRobotDatasetMetadata(REPO_ID, root=root)
    step = 1 / meta.fps
    deltas = {"observation.state": [-step, 0.0], "action": [0.0, step, 2 * step]}
    deltas |= {key: [-step, 0.0] for key in meta.video_keys}
    dataset = LeRobotDataset(REPO_ID, root=root, delta_timestamps=deltas)
    frames = [dataset[i] for i in range(len(dataset))]
    answer: dict[str, Any] = {"frames": len(dataset), "episodes": dataset.num_episodes, "fps": dataset.fps}
    for key in ("observation.state", "action"):
        answer[key] = [frame[key].tolist() for frame in frames]
        answer[f"{key}_is_pad"] = [frame[f"{key}_is_pad"].tolist() for frame in frames]
    answer["episode_index"] = [int(frame["episode_index"]) for frame in frames]
    answer["task"] = sorted({frame["task"] for frame in frames})
    answer["cameras"] = {
        key: {
            "shape": list(frames[0][key].shape),  # (2, 3, H, W): the frame before and this one
            "mean": [[float(image.mean()) for image in frame[key]] for frame in frames],
            "is_pad": [frame[f"{key}_is_pad"].tolist() for frame in frames],
        }
        for key in meta.video_keys
    }
    return answer


def write(root: Path) -> dict[str, Any]:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    vector = {"dtype": "float32", "shape": (6,), "names": SO100_NAMES}
    features = {
        "observation.state": vector,
        "action": vector,
        "observation.images.front": {"dtype": "video", "shape": IMAGE_SHAPE, "names": ["height", "width", "channels"]},
    }
    dataset = LeRobotDataset.create(REPO_ID, fps=FPS, root=root, features=features, robot_type="so100_follower")
    written: list[dict[str, Any]] = []
    for episode, length in enumerate(FRAMES_PER_EPISODE):
        states = [known_state(episode, frame) for frame in range(length)]
        actions = [known_state(episode, frame + 1) for frame in range(length)]  # the command leads by a frame
        for frame in range(length):
            image = np.full(IMAGE_SHAPE, 4 * frame, dtype=np.uint8)
            dataset.add_frame(
                {
                    "observation.state": states[frame],
                    "action": actions[frame],
                    "observation.images.front": image,
                    "task": "wave",
                }
            )
        dataset.save_episode()
        written.append({"state": np.array(states).tolist(), "action": np.array(actions).tolist()})
    dataset.finalize()
    return {"fps": FPS, "names": SO100_NAMES, "episodes": written}


def sac(request: Path) -> dict[str, Any]:
    """A SAC actor (lerobot's own class, no torchvision in it: ACT's backbone is torchvision's ResNet) taking
    `request`'s "inputs" ({key: shape}, images channels first) with an action of `len(action_min)` values, small
    enough to load and run in a moment, saved in `request`'s "out" with its pre/post-processors. The action is
    unnormalized from [-1, 1] over the dataset statistics' [action_min, action_max] (MIN_MAX): where the two are
    equal, the policy commands exactly that action whatever it sees."""
    import torch
    from lerobot.configs.types import FeatureType, PolicyFeature
    from lerobot.policies.factory import make_pre_post_processors
    from lerobot.utils.constants import ACTION, OBS_STATE

    try:  # lerobot 0.6: SAC's policy is its actor, `gaussian_actor` (the critics moved to lerobot.rl)
        from lerobot.policies.gaussian_actor.configuration_gaussian_actor import GaussianActorConfig as SACConfig
        from lerobot.policies.gaussian_actor.modeling_gaussian_actor import GaussianActorPolicy as SACPolicy
    except ModuleNotFoundError:  # lerobot 0.4
        from lerobot.policies.sac.configuration_sac import SACConfig
        from lerobot.policies.sac.modeling_sac import SACPolicy

    spec = json.loads(request.read_text())
    inputs = {
        key: PolicyFeature(FeatureType.STATE if key == OBS_STATE else FeatureType.VISUAL, tuple(shape))
        for key, shape in spec["inputs"].items()
    }
    low, high = (torch.tensor(spec[key], dtype=torch.float32) for key in ("action_min", "action_max"))
    stats = {ACTION: {"min": low, "max": high}}
    for key, feature in inputs.items():
        if feature.type is FeatureType.STATE:
            stats[key] = {"min": torch.full(feature.shape, -180.0), "max": torch.full(feature.shape, 180.0)}
        else:
            stats[key] = {"mean": torch.full((3, 1, 1), 0.5), "std": torch.full((3, 1, 1), 0.25)}
    config = SACConfig(
        device="cpu",
        input_features=inputs,
        output_features={ACTION: PolicyFeature(FeatureType.ACTION, (len(low),))},
        dataset_stats=None,
        image_encoder_hidden_dim=4,
        latent_dim=8,
        state_encoder_hidden_dim=8,
        image_embedding_pooling_dim=2,
        # lerobot 0.4's SACConfig compiles by default; 0.6's actor has no such option
        **({"use_torch_compile": False} if hasattr(SACConfig, "use_torch_compile") else {}),
    )
    torch.manual_seed(0)
    policy = SACPolicy(config)
    preprocessor, postprocessor = make_pre_post_processors(config, dataset_stats=stats)
    out = Path(spec["out"])
    for saved in (policy, preprocessor, postprocessor):
        saved.save_pretrained(out)
    return {"type": config.type, "files": sorted(path.name for path in out.iterdir())}


if __name__ == "__main__":
    command, folder = sys.argv[1], Path(sys.argv[2])
    commands = {"load": load, "delta": delta, "write": write, "normalize": normalize, "sac": sac}
    print(json.dumps(commands[command](folder)))
