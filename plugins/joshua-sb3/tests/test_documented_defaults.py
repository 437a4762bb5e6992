"""The defaults that docs/training-sb3.md and options.proto's comments state are the settings' own.

`joshua_sb3.settings.Settings` resolves every zero of a config to the trainer's default, its one home; the guide's
settings tables and the proto comments restate them for readers, so this test compares each stated default with
what an empty config resolves to, for PPO and for the off-policy algorithms.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

import joshua_sb3
from joshua_core.config_pb2 import TrainingConfig
from joshua_core.defaults import DEFAULT_NUMPY_NUM_ENVS
from joshua_core.options import options_of
from joshua_sb3 import options_pb2
from joshua_sb3.settings import Settings, sb3_settings

GUIDE = Path(__file__).resolve().parents[3] / "docs" / "training-sb3.md"
PROTO = Path(joshua_sb3.__file__).with_name("options.proto")
_NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e-?\d+)?")


def resolved(algorithm: str) -> Settings:
    config = TrainingConfig()
    options_of(config, options_pb2.sb3).algorithm = algorithm
    return sb3_settings(options_of(config, options_pb2.sb3), config)


PPO, SAC = resolved("PPO"), resolved("SAC")
# Guide row (its first field) -> the defaults it states, in order ("64 / 1": PPO's, then SAC's and TD3's).
GUIDE_DEFAULTS: dict[str, tuple[Any, ...]] = {
    "num_envs": (DEFAULT_NUMPY_NUM_ENVS,),
    "total_timesteps": (PPO.total_timesteps,),
    "num_steps": (PPO.num_steps, SAC.num_steps),
    "num_epochs": (PPO.num_epochs, SAC.num_epochs),
    "minibatch_size": (PPO.minibatch_size,),
    "learning_rate": (PPO.learning_rate, PPO.gamma),
    "gae_lambda": (PPO.gae_lambda, PPO.clip_epsilon),
    "seed": (PPO.seed,),
    "algorithm": (PPO.algorithm,),
    "hidden_sizes": PPO.hidden_sizes,
    "entropy_coef": (PPO.entropy_coef,),
}


def stated_defaults() -> dict[str, str]:
    """Each row of the guide's two settings tables: its first field -> its last cell (the default)."""
    text = GUIDE.read_text(encoding="utf-8")
    section = text[text.index("## Settings") :]
    section = section[: section.index("\n## ", 1)]
    return dict(re.findall(r"^\| `(\w+)`[^\n]*\| ([^|\n]*) \|$", section, flags=re.MULTILINE))


def numbers(text: str) -> list[float]:
    return [float(number) for number in _NUMBER.findall(text.replace(",000", "000"))]


@pytest.mark.parametrize("name", list(GUIDE_DEFAULTS))
def test_the_guide_states_the_settings_defaults(name: str) -> None:
    stated, expected = stated_defaults()[name], GUIDE_DEFAULTS[name]
    if isinstance(expected[0], str):
        assert expected[0] in stated, f"{GUIDE.name}: `{name}` says {stated!r}; the settings say {expected[0]!r}"
    else:
        assert numbers(stated) == pytest.approx([float(value) for value in expected]), (
            f"{GUIDE.name}: `{name}` says {stated!r}; the settings say {expected}"
        )


def test_the_proto_comments_state_the_settings_defaults() -> None:
    text = PROTO.read_text(encoding="utf-8")
    hidden = re.search(r"training\.hidden_sizes: [^;]*empty: ([\d, ]+);", text)
    assert hidden is not None and numbers(hidden[1]) == [float(size) for size in PPO.hidden_sizes]
    algorithm = re.search(r'// Algorithm: "(\w+)" \(default\)', text)
    assert algorithm is not None and algorithm[1] == PPO.algorithm
