"""A trained policy described without its training framework, so that any exporter can rebuild it.

`Trainer.export_policy` returns an `ExportedPolicy`: the run's training config (task, model, task
overrides) and its deterministic policy as a plain MLP of numpy arrays (`MlpPolicy`). Flax and torch
policies become the same description, so one exporter (joshua-export writes ONNX) serves every trainer
without the core or the exporter knowing either framework.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from joshua_core.errors import UsageError

if TYPE_CHECKING:
    from joshua_core.config_pb2 import TrainingConfig

# Activations between hidden layers, by the names MlpPolicy uses (swish is x * sigmoid(x), torch's SiLU).
ACTIVATIONS = ("relu", "tanh", "elu", "swish")
# What the last layer's output goes through before the action is clipped to [-1, 1].
OUTPUTS = ("identity", "tanh")


@dataclass(frozen=True)
class DenseLayer:
    """y = x @ weight + bias: weight (inputs, outputs), bias (outputs,), float32."""

    weight: NDArray[np.float32]
    bias: NDArray[np.float32]


@dataclass(frozen=True)
class MlpPolicy:
    """The deterministic policy: action = clip(output(mlp(normalized)), -1, 1), where
    normalized = clip((obs - obs_mean) / obs_std, -obs_clip, obs_clip).

    `mlp` applies `activation` after every layer but the last. Without observation normalisation the
    mean is 0, the std 1 and the clip infinite. The normalisation is computed in float64 (as SB3's
    VecNormalize does: a small std would amplify float32 rounding), the layers in float32. The result is
    the action in [-1, 1] the task maps to
    controls (`joshua_core.tasks.Task.action_to_ctrl`), the mean action the trainer's `evaluate` sends.
    """

    layers: tuple[DenseLayer, ...]
    activation: str
    obs_mean: NDArray[np.float64]
    obs_std: NDArray[np.float64]
    obs_clip: float
    output: str = "identity"

    def __post_init__(self) -> None:
        if self.activation not in ACTIVATIONS or self.output not in OUTPUTS:
            raise UsageError(
                f"policy activation '{self.activation}' / output '{self.output}' cannot be exported "
                f"(activations: {', '.join(ACTIVATIONS)}; outputs: {', '.join(OUTPUTS)})"
            )
        sizes = [self.obs_mean.shape[0]] + [layer.weight.shape[1] for layer in self.layers]
        inputs = [layer.weight.shape[0] for layer in self.layers]
        if not self.layers or inputs != sizes[:-1] or self.obs_std.shape != self.obs_mean.shape:
            raise UsageError(f"policy layers do not chain: inputs {inputs}, outputs {sizes}")

    @property
    def observation_size(self) -> int:
        return int(self.obs_mean.shape[0])

    @property
    def action_size(self) -> int:
        return int(self.layers[-1].weight.shape[1])


@dataclass(frozen=True)
class ExportedPolicy:
    """A run's policy for export: who trained it, from which checkpoint, on what (`training`), and the MLP."""

    trainer: str
    checkpoint: Path
    training: TrainingConfig
    policy: MlpPolicy
