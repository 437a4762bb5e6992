"""An SB3 checkpoint's deterministic policy as a framework-free MLP (`joshua_core.policy.MlpPolicy`), for export.

The action `model.predict(obs, deterministic=True)` gives for observations normalised as VecNormalize does:
PPO's Gaussian mean (mlp_extractor.policy_net, then action_net) clipped to [-1, 1]; SAC's tanh of its mean
(latent_pi, then mu); TD3's actor (mu, ending in tanh). Every MlpPolicy flattens its Box observation.
"""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.torch_layers import FlattenExtractor
from torch import nn

from joshua_core.errors import CorruptCheckpointError, JoshuaError, UsageError
from joshua_core.policy import DenseLayer, MlpPolicy
from joshua_sb3.run_folder import MODEL_FILE, NORMALIZATION_FILE, verify_checkpoint

EXPORT_TRUST_HINT = "joshua export RUN --trust-checkpoint"
_ACTIVATIONS: dict[type[nn.Module], str] = {nn.ReLU: "relu", nn.Tanh: "tanh", nn.ELU: "elu", nn.SiLU: "swish"}


def saved_policy(checkpoint: Path, algorithm: type[BaseAlgorithm], *, trust: bool, device: str) -> MlpPolicy:
    """The deterministic policy of an SB3 checkpoint, after checking its files may be unpickled."""
    normalizer = checkpoint / NORMALIZATION_FILE
    names = [MODEL_FILE] + [NORMALIZATION_FILE] * normalizer.is_file()
    verify_checkpoint(checkpoint, names, trust=trust, trust_hint=EXPORT_TRUST_HINT)
    try:
        model = algorithm.load(checkpoint / MODEL_FILE, device=device)
        size = int(np.prod(model.observation_space.shape))
        return mlp_of(policy_modules(model), normalizer if normalizer.is_file() else None, size)
    except JoshuaError:
        raise
    except Exception as error:  # a damaged file can fail in any way inside SB3, zip or pickle
        message = f"cannot load checkpoint '{checkpoint}': {type(error).__name__}: {error}"
        raise CorruptCheckpointError(message) from None


def policy_modules(model: BaseAlgorithm) -> list[nn.Module]:
    """The modules from the (flattened) observation to the action, in order, of a PPO, SAC or TD3 model."""
    policy = model.policy
    extractors = [getattr(policy, name, None) for name in ("features_extractor", "pi_features_extractor")]
    actor = getattr(policy, "actor", None)
    if actor is not None:  # SAC, TD3
        extractors.append(actor.features_extractor)
    if any(extractor is not None and not isinstance(extractor, FlattenExtractor) for extractor in extractors):
        raise UsageError(f"{type(model).__name__}'s policy does not take the flat observation: it cannot be exported")
    if hasattr(policy, "mlp_extractor"):  # PPO's ActorCriticPolicy: a Gaussian; its mean, clipped
        return [*policy.mlp_extractor.policy_net, policy.action_net]
    if hasattr(actor, "latent_pi"):  # SAC: tanh of the Gaussian's mean
        if getattr(actor, "use_sde", False):
            raise UsageError("a SAC policy with generalized state-dependent exploration cannot be exported")
        return [*actor.latent_pi, actor.mu, nn.Tanh()]
    return list(actor.mu)  # TD3: the deterministic actor, ending in tanh


def mlp_of(modules: list[nn.Module], normalizer_path: Path | None, observation_size: int) -> MlpPolicy:
    """The MLP of `modules` (Linear layers with one kind of activation between them, maybe a tanh after the
    last), with the observation statistics of the VecNormalize pickled at `normalizer_path` (None: none)."""
    layers: list[DenseLayer] = []
    between: list[str] = []  # the activation after each Linear layer ("identity": none)
    for module in modules:
        if isinstance(module, nn.Linear):
            weight = module.weight.detach().cpu().numpy().T.astype(np.float32)
            bias = module.bias.detach().cpu().numpy().astype(np.float32)
            layers.append(DenseLayer(np.ascontiguousarray(weight), bias))
            between.append("identity")
        elif layers and between[-1] == "identity" and _activation(module):
            between[-1] = _activation(module)
        else:
            raise UsageError(f"the policy has a {type(module).__name__} layer where none can be exported")
    if not layers:
        raise UsageError("the policy has no Linear layer to export")
    hidden, output = set(between[:-1]), between[-1]
    if len(hidden) > 1 or "identity" in hidden or output not in ("identity", "tanh"):
        raise UsageError(
            f"the policy's activations {between} cannot be exported (one kind between layers, tanh or none last)"
        )
    mean, std, clip = _normalizer(normalizer_path, observation_size)
    return MlpPolicy(tuple(layers), hidden.pop() if hidden else "relu", mean, std, clip, output)


def _activation(module: nn.Module) -> str:
    """The MlpPolicy name of an activation module ("" when it is none that can be exported)."""
    if isinstance(module, nn.ELU) and module.alpha != 1.0:
        return ""
    return _ACTIVATIONS.get(type(module), "")


def _normalizer(path: Path | None, size: int) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """(mean, std, clip) of VecNormalize's observation normalisation: clip((obs - mean) / sqrt(var + eps))."""
    if path is None:
        return np.zeros(size), np.ones(size), float("inf")
    with path.open("rb") as handle:
        normalizer = pickle.load(handle)  # verified (signed by this user, or trusted) before it gets here
    if not normalizer.norm_obs:
        return np.zeros(size), np.ones(size), float("inf")
    statistics = normalizer.obs_rms
    std = np.sqrt(np.asarray(statistics.var, np.float64) + normalizer.epsilon)
    return np.asarray(statistics.mean, np.float64), std, float(normalizer.clip_obs)
