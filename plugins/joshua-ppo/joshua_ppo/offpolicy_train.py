"""The off-policy trainers' algorithm without a run around it: `train_offpolicy` (the shared training loop over
`joshua_ppo.offpolicy_iteration`), the actor's deterministic policy, and what a checkpoint saves and resuming
loads. `joshua_ppo.offpolicy_trainer` adds run folders, monitors, eval and export; benches use this alone.

A checkpoint holds the actor as PPO's holds its policy (params.msgpack: {"params", "normalizer"}, so `joshua
export` and a user's script read either alike) and in train_state.msgpack the critics, target networks,
optimisers, temperature and random key. The replay buffer is not saved (hundreds of megabytes of experience the
environments make again in seconds): a resumed run collects `learning_starts` steps before it updates again.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import jax
from flax import serialization

from joshua_core.errors import CorruptCheckpointError
from joshua_ppo.checkpoints import PARAMS_FILE, TRAIN_STATE_FILE, NetworkMismatchError, _restore, payload_bytes
from joshua_ppo.envs import JaxEnv
from joshua_ppo.normalizer import RunningStatistics, normalize
from joshua_ppo.offpolicy_iteration import (
    OffPolicyState,
    abstract_state,
    init_state,
    make_actor,
    make_iteration,
    state_shardings,
)
from joshua_ppo.offpolicy_networks import deterministic_action
from joshua_ppo.offpolicy_settings import OffPolicySettings, check_batch
from joshua_ppo.policy import camera_views
from joshua_ppo.rollout import Act
from joshua_ppo.settings import NetworkSettings
from joshua_ppo.state import Progress
from joshua_ppo.train import CheckpointCallback, ProgressCallback, run_iterations

RUN_FORMAT = "joshua-offpolicy-run/1"  # the "format" of an off-policy run's and its checkpoints' config.json


def offpolicy_policy(env: JaxEnv, settings: OffPolicySettings) -> Act:
    """The actor's deterministic policy (tanh of its mean), as rollouts take it."""
    actor = make_actor(env, settings)
    gaussian = settings.algorithm == "sac"

    def act(params: Any, stats: RunningStatistics, state: Any) -> jax.Array:
        observation = normalize(stats, state.observation, settings.normalize_observations)
        head = actor.apply({"params": params}, observation, camera_views(state, settings.pixels))
        return deterministic_action(head, gaussian)  # type: ignore[arg-type]  # without mutable, apply gives the output alone

    return act


def exported_network(settings: OffPolicySettings) -> NetworkSettings:
    """The actor described as PPO's policy network, which `joshua_ppo.export.mlp_policy` reads: the same hidden
    layers and normaliser, a tanh output, and for SAC a head whose first half is the mean."""
    return NetworkSettings(
        hidden_sizes=settings.actor_hidden_sizes,
        normalize_observations=settings.normalize_observations,
        squash_actions=True,
        activation=settings.activation,
        state_dependent_std=settings.algorithm == "sac",
        pixels=settings.pixels,
    )


def train_offpolicy(
    env: JaxEnv,
    settings: OffPolicySettings,
    *,
    resume: tuple[OffPolicyState, Progress] | None = None,
    on_progress: ProgressCallback | None = None,
    on_checkpoint: CheckpointCallback | None = None,
    should_stop: Callable[[], bool] | None = None,
) -> tuple[OffPolicyState, Progress]:
    """TD3 or SAC (`settings.algorithm`) until `settings.total_timesteps`, reporting and checkpointing as
    `joshua_ppo.train.train_ppo` does (its loop, `run_iterations`)."""
    check_batch(settings, env.num_envs, env.mesh.size)
    started = time.perf_counter()
    return run_iterations(
        env,
        make_iteration(env, settings),
        abstract_state(env, settings),
        lambda: init_state(env, settings),
        steps_per_iteration=env.num_envs * settings.steps_per_iteration,
        total_timesteps=settings.total_timesteps,
        checkpoint_interval=settings.checkpoint_interval,
        resume=resume,
        on_progress=on_progress,
        on_checkpoint=on_checkpoint,
        should_stop=should_stop,
        started=started,
    )


def checkpoint_payloads(state: OffPolicyState, progress: Progress) -> dict[str, Any]:
    """Host copies of what a checkpoint saves: the actor and normaliser (PARAMS_FILE), and what resuming needs
    besides them (TRAIN_STATE_FILE); not the environments nor the replay buffer."""
    learner = state.learner._replace(actor=None)
    params = {"params": state.learner.actor, "normalizer": state.normalizer._asdict()}
    train_state = {
        "learner": learner._asdict(),
        "key": state.key,
        "iteration": progress.iteration,
        "env_steps": progress.env_steps,
    }
    return {PARAMS_FILE: jax.device_get(params), TRAIN_STATE_FILE: jax.device_get(train_state)}


def load_actor(
    checkpoint: Path, env: JaxEnv, settings: OffPolicySettings, data: bytes | None = None
) -> tuple[Any, RunningStatistics]:
    """A checkpoint's actor and normaliser (from `data`, its params file's bytes, when given), checked against the
    actor its settings describe; host arrays."""
    template = abstract_state(env, settings)
    path = checkpoint / PARAMS_FILE
    raw = _restore(path, payload_bytes(checkpoint, PARAMS_FILE) if data is None else data, None)
    expected = jax.tree.map(lambda leaf: leaf.shape, serialization.to_state_dict(template.learner.actor))
    saved = raw.get("params") if isinstance(raw, dict) else None
    if saved is None or jax.tree.map(lambda leaf: tuple(leaf.shape), saved) != expected:
        raise NetworkMismatchError(
            f"{path} holds an actor of other sizes than its config.json describes "
            f"(actor_hidden_sizes {list(settings.actor_hidden_sizes)}); was the config edited?"
        )
    target = {"params": template.learner.actor, "normalizer": template.normalizer._asdict()}
    try:
        restored = serialization.from_state_dict(target, raw)
    except Exception as error:  # flax raises many types for a normaliser of another size
        raise CorruptCheckpointError(f"cannot load {path}: {type(error).__name__}: {error}") from None
    return restored["params"], RunningStatistics(**restored["normalizer"])


def load_state(
    checkpoint: Path, env: JaxEnv, settings: OffPolicySettings, payloads: dict[str, bytes]
) -> tuple[OffPolicyState, Progress]:
    """The training state of a checkpoint with fresh environments and an empty replay buffer, for resuming."""
    fresh = init_state(env, settings)
    params, normalizer = load_actor(checkpoint, env, settings, payloads[PARAMS_FILE])
    learner = fresh.learner._replace(actor=None)
    target = {"learner": learner._asdict(), "key": fresh.key, "iteration": 0, "env_steps": 0}
    saved = _restore(checkpoint / TRAIN_STATE_FILE, payloads[TRAIN_STATE_FILE], jax.device_get(target))
    restored = type(learner)(**saved["learner"])._replace(actor=params)
    state = fresh._replace(normalizer=normalizer, learner=restored, key=saved["key"])
    state = jax.device_put(state, state_shardings(env, state))
    return state, Progress(int(saved["iteration"]), int(saved["env_steps"]))
