"""A PPO checkpoint's deterministic policy as a framework-free MLP (`joshua_core.policy.MlpPolicy`), for export.

Read straight from params.msgpack, without building the environments or the network: Flax names the
layers of the compact modules in `joshua_ppo.networks` Dense_0, Dense_1, ... in the order they are made,
so the policy's layers are the first len(policy hidden sizes) + 1 of them (trunk, then the mean head;
the value layers come after). A state-dependent std head's first half is the mean.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from joshua_core.errors import ConfigError, CorruptCheckpointError
from joshua_core.policy import DenseLayer, MlpPolicy
from joshua_ppo.checkpoints import PARAMS_FILE, NetworkMismatchError, _restore, payload_bytes
from joshua_ppo.settings import OBSERVATION_CLIP, NetworkSettings

_NORMALIZER_EPSILON = 1e-8  # as joshua_ppo.normalizer.normalize


def mlp_policy(checkpoint: Path, network: NetworkSettings) -> MlpPolicy:
    """The mean action of the policy saved in `checkpoint` (squashed when the network squashes), as an MLP."""
    if network.pixels is not None:
        raise ConfigError(
            f"the policy of {checkpoint} sees camera images: only policies of the flat observation export as an MLP"
        )
    path = checkpoint / PARAMS_FILE
    try:
        saved = _restore(path, payload_bytes(checkpoint, PARAMS_FILE), None)
        params, normalizer = saved["params"], saved["normalizer"]
        mean = np.asarray(normalizer["mean"], np.float32)
        variance = np.asarray(normalizer["variance"], np.float32)
    except (KeyError, TypeError) as error:
        raise CorruptCheckpointError(f"{path} has no {error} entry: not a PPO checkpoint") from None
    layers = _policy_layers(path, params, network)
    if network.normalize_observations:  # the std as the trainer computes it, in float32
        std, clip = np.sqrt(variance + np.float32(_NORMALIZER_EPSILON)), OBSERVATION_CLIP
    else:
        mean, std, clip = np.zeros_like(mean), np.ones_like(mean), float("inf")
    return MlpPolicy(
        layers=layers,
        activation=network.activation,
        obs_mean=mean.astype(np.float64),
        obs_std=std.astype(np.float64),
        obs_clip=clip,
        output="tanh" if network.squash_actions else "identity",
    )


def _policy_layers(path: Path, params: Any, network: NetworkSettings) -> tuple[DenseLayer, ...]:
    """Dense_0 .. Dense_k of the saved parameters, k the number of policy hidden layers; the head cut to the mean."""
    count = len(network.hidden_sizes) + 1
    names = [f"Dense_{index}" for index in range(count)]
    mismatch = NetworkMismatchError(
        f"{path} holds a network of other sizes than its config.json describes "
        f"(hidden_sizes {list(network.hidden_sizes)}); was the config edited?"
    )
    try:
        layers = [
            DenseLayer(np.asarray(params[name]["kernel"], np.float32), np.asarray(params[name]["bias"], np.float32))
            for name in names
        ]
    except (KeyError, TypeError):
        raise mismatch from None
    if [layer.weight.shape[1] for layer in layers[:-1]] != list(network.hidden_sizes):
        raise mismatch
    if network.state_dependent_std:  # the head outputs mean and raw std side by side
        head = layers[-1]
        half = head.weight.shape[1] // 2
        layers[-1] = DenseLayer(head.weight[:, :half], head.bias[:half])
    return tuple(layers)
