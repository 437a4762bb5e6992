"""The off-policy trainers' pieces without training: the replay ring, n-step targets against hand-computed values,
the random-shift augmentation of a pixel batch, the losses, and bad settings as one-line config errors."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from joshua_core.config_pb2 import TrainingConfig
from joshua_core.errors import ConfigError
from joshua_core.options import parse_dict
from joshua_core.plugins import PluginHost
from joshua_ppo import options_pb2
from joshua_ppo.offpolicy_iteration import random_shift
from joshua_ppo.offpolicy_losses import critic_loss, critic_target
from joshua_ppo.offpolicy_networks import squashed_gaussian
from joshua_ppo.offpolicy_settings import check_batch, offpolicy_settings
from joshua_ppo.options_pb2 import OffPolicyOptions
from joshua_ppo.replay import Step, add, empty_replay, n_step_return, sample

GAMMA = 0.9


def test_n_step_returns_stop_at_an_episodes_end() -> None:
    """Three rows of three steps: no end, a truncation at step 1, a termination at step 0 (hand-computed)."""
    rewards = jnp.array([[1.0, 2.0, 4.0], [1.0, 2.0, 4.0], [1.0, 2.0, 4.0]])
    ended = jnp.array([[False, False, False], [False, True, False], [True, False, False]])
    terminated = jnp.array([[False, False, False], [False, False, False], [True, False, False]])
    total, discount, last = n_step_return(rewards, ended, terminated, GAMMA)
    np.testing.assert_allclose(total, [1 + 0.9 * 2 + 0.81 * 4, 1 + 0.9 * 2, 1.0], rtol=1e-6)
    np.testing.assert_allclose(discount, [0.9**3, 0.9**2, 0.0], rtol=1e-6)
    assert last.tolist() == [2, 1, 0]


def _step(t: int, envs: int = 2, ended: bool = False) -> Step:
    """Step t of `envs` environments: observation t (environment e adds 100 e), reward t, next observation t + 0.5."""
    base = jnp.arange(envs, dtype=jnp.float32) * 100 + t
    flags = jnp.full((envs,), ended)
    return Step(base[:, None], None, None, base[:, None], base, flags, flags, base[:, None] + 0.5, None)


def test_the_ring_keeps_the_newest_steps_and_samples_n_step_transitions_inside_them() -> None:
    replay = empty_replay(_step(0), capacity=4)
    for t in range(6):  # steps 2..5 stay: slots hold 4, 5, 2, 3
        replay = jax.jit(add)(replay, _step(t, ended=t == 3))
    assert int(replay.count) == 4 and int(replay.position) == 2
    np.testing.assert_allclose(replay.reward[:, 0], [4, 5, 2, 3])
    draw = jax.jit(sample, static_argnums=(2, 3, 4))
    batch = jax.device_get(draw(replay, jax.random.PRNGKey(0), 256, 2, GAMMA))  # host arrays: read row by row
    start = np.asarray(batch.observation[:, 0]) % 100
    # starts whose two steps and the slot after them are written: steps 2 and 3 (not 4 or 5)
    assert set(start.tolist()) == {2.0, 3.0}
    env = np.asarray(batch.observation[:, 0]) // 100
    for row in range(256):
        offset = 100 * env[row]
        if start[row] == 2:  # steps 2 and 3; step 3 ends its (terminated) episode: no bootstrap
            expected = (offset + 2 + GAMMA * (offset + 3), 0.0, offset + 3.5)
        else:  # step 3 ends the episode at once
            expected = (offset + 3, 0.0, offset + 3.5)
        assert batch.reward[row] == pytest.approx(expected[0])
        assert batch.discount[row] == pytest.approx(expected[1])
        assert batch.next_observation[row, 0] == pytest.approx(expected[2])
    np.testing.assert_allclose(batch.action, batch.observation)  # the action of the same step


def test_random_shift_moves_each_image_by_at_most_the_shift_and_keeps_shapes() -> None:
    images = jnp.zeros((64, 12, 10, 3), jnp.uint8).at[:, 6, 5, :].set(255)  # one bright pixel
    shifted = np.asarray(jax.jit(random_shift, static_argnums=2)(images, jax.random.PRNGKey(1), 2))
    assert shifted.shape == images.shape and shifted.dtype == np.uint8
    rows, cols = np.nonzero(shifted[..., 0].max(axis=0))
    assert set(rows.tolist()) <= set(range(4, 9)) and set(cols.tolist()) <= set(range(3, 8))
    positions = {tuple(np.argwhere(image[..., 0])[0]) for image in shifted}
    assert len(positions) > 5  # each image its own offset


def test_losses_and_the_squashed_gaussian() -> None:
    target = critic_target(jnp.array([1.0, 2.0]), jnp.array([0.5, 0.0]), jnp.array([[4.0, -2.0], [3.0, 5.0]]))
    np.testing.assert_allclose(target, [1.0 + 0.5 * 3.0, 2.0])  # the smaller target critic, no bootstrap at 0
    # errors 0, 0 (first critic) and 0, 1 (second): half the squares summed over critics, averaged over the batch
    assert float(critic_loss(jnp.array([[2.5, 2.0], [2.5, 3.0]]), target)) == pytest.approx(0.25)
    head = jnp.array([[0.3, -0.2, 0.0, 0.0]])  # mean (0.3, -0.2), raw log-std 0
    action, log_prob = squashed_gaussian(head, jnp.zeros((1, 2)))
    np.testing.assert_allclose(action, jnp.tanh(jnp.array([[0.3, -0.2]])), rtol=1e-6)
    log_std = -5.0 + 0.5 * 7.0  # the bounds' middle
    expected = sum(-log_std - 0.5 * np.log(2 * np.pi) - np.log(1 - np.tanh(m) ** 2) for m in (0.3, -0.2))
    assert float(log_prob[0]) == pytest.approx(expected, rel=1e-5)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"minibatch_size": -1}, "training.minibatch_size must not be negative"),
        ({"learning_rate": -0.1}, "training.learning_rate must not be negative"),
        ({"offpolicy": {"tau": 2.0}}, "training.offpolicy.tau must be at most 1"),
        ({"offpolicy": {"tau": -1.0}}, "training.offpolicy.tau must not be negative"),
        ({"offpolicy": {"n_step": 8, "learning_starts": 8}}, "learning_starts 8 must be more than n_step 8"),
        ({"offpolicy": {"replay_steps": 4}}, "replay_steps 4 must be at least learning_starts 8"),
        ({"offpolicy": {"critic_hidden_sizes": [0]}}, "critic_hidden_sizes must be positive"),
        ({"offpolicy": {"exploration_std_min": 0.5, "exploration_std_max": 0.1}}, "is above exploration_std_max"),
    ],
)
def test_bad_settings_are_config_errors(options: dict, message: str) -> None:
    config = TrainingConfig(trainer="td3")
    parse_dict(options, config, PluginHost.discover().options())
    with pytest.raises(ConfigError, match=message):
        offpolicy_settings(config.Extensions[options_pb2.offpolicy], config)


def test_a_minibatch_larger_than_the_first_buffer_is_a_config_error() -> None:
    settings = offpolicy_settings(OffPolicyOptions(), TrainingConfig(trainer="sac", minibatch_size=4096))
    check_batch(settings, num_envs=512, devices=1)
    with pytest.raises(ConfigError, match="minibatch_size 4096 is more than the 2048 transitions the buffer holds"):
        check_batch(settings, num_envs=256, devices=1)
