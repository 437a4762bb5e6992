"""The labels of `joshua eval --grid` tiles: the return so far, then the episode's return and outcome, held."""

from __future__ import annotations

import numpy as np

from joshua_ppo.rollout import Rollout, episode_results, tile_label


def rollout() -> Rollout:
    """Two filmed environments: env 0 ends after 2 steps and succeeds, env 1 fails after 3."""
    return Rollout(
        qpos=[np.zeros((3, 1)), np.zeros((4, 1))],
        commands=[{}, {}],
        running_returns=[np.array([0.0, 1.0, 2.5]), np.array([0.0, -1.0, -2.0, -3.0])],
        finished=np.array([0, 1]),
        returns=np.array([3.5, -4.0]),
        lengths=np.array([3, 4]),
        metrics={"success": np.array([1.0, 0.0]), "distance": np.array([0.01, 0.2])},
        failed=np.array([False, False]),
    )


def test_tiles_show_the_return_so_far_then_the_outcome_until_the_longest_episode_ends() -> None:
    recorded = rollout()
    assert [tile_label(recorded, 0, frame) for frame in range(4)] == [
        "episode 1  return 0",
        "episode 1  return 1",
        "episode 1  return 3.5  success",
        "episode 1  return 3.5  success",  # held while episode 2 goes on
    ]
    assert tile_label(recorded, 1, 2) == "episode 2  return -2"
    assert tile_label(recorded, 1, 3) == "episode 2  return -4  failure"


def test_without_a_success_metric_the_final_label_has_no_outcome_and_results_are_per_episode() -> None:
    recorded = rollout()
    recorded.metrics = {"distance": recorded.metrics["distance"]}
    assert tile_label(recorded, 0, 2) == "episode 1  return 3.5"
    results = episode_results(recorded)
    assert results.returns == [3.5, -4.0] and results.lengths == [3, 4] and results.metrics == {"distance": [0.01, 0.2]}
    assert results.failed == [False, False]
