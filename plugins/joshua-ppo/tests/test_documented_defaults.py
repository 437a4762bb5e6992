"""The defaults that options.proto's comments and docs/training-mjx.md state are the settings' own.

`joshua_ppo.settings` is the one home of PPO's defaults; the proto comments ("0: 0.5") and the docs' option table
restate them for readers, so this test reads both and compares every stated default with what an empty config
resolves to (`ppo_settings`).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

import joshua_ppo
from joshua_core.config_pb2 import TrainingConfig
from joshua_ppo.config_settings import DEFAULT_TOTAL_TIMESTEPS, ppo_settings
from joshua_ppo.envs import DEFAULT_NUM_ENVS
from joshua_ppo.options_pb2 import PpoOptions
from joshua_ppo.settings import PixelSettings, TeacherSettings

PROTO = Path(joshua_ppo.__file__).with_name("options.proto")
GUIDE = Path(__file__).resolve().parents[3] / "docs" / "training-mjx.md"
RESOLVED = ppo_settings(PpoOptions(), TrainingConfig())
PIXELS = PixelSettings(cameras=("camera",))
_NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e-?\d+)?")

# (message, field) of options.proto -> the default an empty config resolves it to.
PROTO_DEFAULTS: dict[tuple[str, str], Any] = {
    ("PpoOptions", "activation"): RESOLVED.network.activation,
    ("PpoOptions", "reward_scaling"): RESOLVED.returns.reward_scaling,
    ("PpoOptions", "unrolls_per_iteration"): RESOLVED.rollout.unrolls_per_iteration,
    ("PpoOptions", "max_grad_norm"): RESOLVED.optimization.max_grad_norm,
    ("PpoOptions", "value_coef"): RESOLVED.optimization.value_coef,
    ("PpoOptions", "viewer_envs"): RESOLVED.run.viewer_envs,
    ("PixelOptions", "channels"): PIXELS.channels,
    ("PixelOptions", "kernel_sizes"): PIXELS.kernel_sizes,
    ("PixelOptions", "strides"): PIXELS.strides,
    ("PixelOptions", "feature_size"): PIXELS.feature_size,
    ("Teacher", "weight"): TeacherSettings(run="run").weight,
}
# PpoOptions field -> its default as the guide's option table states it.
GUIDE_DEFAULTS: dict[str, Any] = {
    "hidden_sizes": RESOLVED.network.hidden_sizes,
    "activation": RESOLVED.network.activation,
    "entropy_coef": RESOLVED.optimization.entropy_coef,
    "value_coef": RESOLVED.optimization.value_coef,
    "reward_scaling": RESOLVED.returns.reward_scaling,
    "unrolls_per_iteration": RESOLVED.rollout.unrolls_per_iteration,
    "max_grad_norm": RESOLVED.optimization.max_grad_norm,
    "advantage": RESOLVED.returns.advantage,
    "desired_kl": RESOLVED.optimization.desired_kl,
    "max_kl": RESOLVED.optimization.max_kl,
    "viewer_envs": RESOLVED.run.viewer_envs,
}
# The guide's sentence of the TrainingConfig fields PPO reads: name -> default.
TRAINING_DEFAULTS: dict[str, Any] = {
    "num_steps": RESOLVED.rollout.num_steps,
    "num_epochs": RESOLVED.optimization.num_epochs,
    "minibatch_size": RESOLVED.optimization.minibatch_size,
    "learning_rate": RESOLVED.optimization.learning_rate,
    "gamma": RESOLVED.returns.gamma,
    "gae_lambda": RESOLVED.returns.gae_lambda,
    "clip_epsilon": RESOLVED.optimization.clip_epsilon,
}


def field_comments(message: str) -> dict[str, str]:
    """Each field of `message` in options.proto -> the comment lines just above it and on its line."""
    lines = PROTO.read_text(encoding="utf-8").splitlines()
    start = lines.index(f"message {message} {{")
    comments: dict[str, str] = {}
    pending: list[str] = []
    depth = 0
    for line in lines[start:]:
        depth += line.count("{") - line.count("}")
        code, _, comment = line.partition("//")
        field = re.match(r"\s*(?:repeated\s+)?[\w.]+\s+(\w+)\s*=\s*\d+\s*;", code)
        if field and depth == 1:
            comments[field[1]] = " ".join([*pending, comment])
        pending = [*pending, comment] if not code.strip() and comment else []  # a comment block ends at code
        if depth == 0 and line.strip() == "}":
            return comments
    raise AssertionError(f"message {message} has no end in {PROTO}")


def states(text: str, value: Any) -> bool:
    """Whether `text` (a stated default) says `value`: the same numbers in order, or the word."""
    if isinstance(value, str):
        return value.lower() in text.lower()
    numbers = [float(number) for number in _NUMBER.findall(text)]
    expected = [float(item) for item in value] if isinstance(value, tuple) else [float(value)]
    return numbers[: len(expected)] == pytest.approx(expected)


@pytest.mark.parametrize(("message", "field"), list(PROTO_DEFAULTS))
def test_the_proto_comments_state_the_settings_defaults(message: str, field: str) -> None:
    comment = field_comments(message)[field]
    stated = re.search(r"(?:\b0|empty): ([^;]+?)(?:;|\.(?:\s|$)|$)", comment)
    assert stated is not None, f"{message}.{field}: its comment states no default: {comment!r}"
    assert states(stated[1], PROTO_DEFAULTS[(message, field)]), (
        f"{PROTO.name}: {message}.{field} says {stated[1]!r}; the settings say {PROTO_DEFAULTS[(message, field)]!r}"
    )


def test_the_proto_comments_state_the_shared_hidden_sizes_default() -> None:
    """training.hidden_sizes is the core's field, whose comment leaves its default to the trainer: PpoOptions says
    it beside value_hidden_sizes."""
    stated = re.search(r"training\.hidden_sizes, empty: ([\d, ]+)\.", " ".join(field_comments("PpoOptions").values()))
    assert stated is not None and states(stated[1], RESOLVED.network.hidden_sizes), stated


def test_the_guide_states_the_settings_defaults() -> None:
    text = GUIDE.read_text(encoding="utf-8")
    section = text[text.index("## PPO options") :]
    section = section[: section.index("\n## ", 1)]
    rows = dict(re.findall(r"^\| `(\w+)` \| ([^|]+) \|", section, flags=re.MULTILINE))
    wrong = {name: rows.get(name) for name, value in GUIDE_DEFAULTS.items() if not states(rows.get(name, ""), value)}
    assert not wrong, f"{GUIDE.name}#ppo-options states defaults the settings do not have: {wrong}"
    sentence = section[: section.index("| field |")]
    for name, value in TRAINING_DEFAULTS.items():
        stated = re.search(rf"`{name}` ({_NUMBER.pattern})", sentence)
        assert stated is not None and states(stated[1], value), f"{GUIDE.name}: `{name}` is {value}"
    assert f"{DEFAULT_NUM_ENVS} environments" in sentence
    assert f"{DEFAULT_TOTAL_TIMESTEPS // 1_000_000} M steps" in sentence
