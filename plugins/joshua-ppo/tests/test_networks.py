"""The policy networks' distributions: the squashed policy's entropy estimate against numerical
integration, and the state-dependent std."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from joshua_ppo.networks import SeparateActorCritic, gaussian_entropy, squashed_entropy


def tanh_gaussian_entropy_by_integration(mean: float, std: float) -> float:
    """Differential entropy of y = tanh(u), u ~ N(mean, std^2), integrated over a fine grid of y."""
    y = np.linspace(-1.0, 1.0, 2_000_001)[1:-1]
    u = np.arctanh(y)
    density = np.exp(-0.5 * ((u - mean) / std) ** 2) / (std * math.sqrt(2 * math.pi)) / (1.0 - y * y)
    integrand = np.where(density > 0, -density * np.log(np.where(density > 0, density, 1.0)), 0.0)
    return float(np.sum(integrand) * (y[1] - y[0]))


@pytest.mark.parametrize(("mean", "std"), [(0.0, 0.3), (0.3, 0.8), (-1.0, 2.0)])
def test_squashed_entropy_estimates_the_entropy_of_the_tanh_actions(mean: float, std: float) -> None:
    noise = jax.random.normal(jax.random.PRNGKey(0), (400_000, 1))
    estimate = squashed_entropy(jnp.full((1,), mean), jnp.full((1,), math.log(std)), noise).mean()
    assert float(estimate) == pytest.approx(tanh_gaussian_entropy_by_integration(mean, std), abs=0.01)


def test_squashed_entropy_stops_growing_with_the_std_where_the_gaussians_does_not() -> None:
    noise = jax.random.normal(jax.random.PRNGKey(1), (100_000, 8))
    wide, wider = (squashed_entropy(jnp.zeros(8), jnp.full(8, math.log(s)), noise).mean() for s in (2.0, 8.0))
    assert wider < wide < 8 * math.log(2.0)  # log 2 per dimension: the most any distribution on [-1, 1] has
    assert gaussian_entropy(jnp.full(8, math.log(8.0))) > gaussian_entropy(jnp.full(8, math.log(2.0)))


def test_state_dependent_std_is_an_output_of_the_policy_network() -> None:
    net = SeparateActorCritic(3, (16,), (16,), activation="swish", state_dependent_std=True)
    observations = jax.random.normal(jax.random.PRNGKey(2), (5, 4))
    params = net.init(jax.random.PRNGKey(3), observations)["params"]
    mean, log_std, value = net.apply({"params": params}, observations)
    assert mean.shape == log_std.shape == (5, 3) and value.shape == (5,)
    assert "log_std" not in params
    assert float(jnp.std(log_std[:, 0])) > 0.0  # differs between observations
    assert bool(jnp.all(jnp.exp(log_std) >= 1e-3))
