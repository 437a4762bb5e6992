"""A scripted controller picks up the cube and places it on the goal on the CPU scene (mujoco.batch), through the
task's own environments, for both arms (the SO-ARM100's and the SO-101's task): the task is solvable and the
reward stages fire in order (reach, grasp, lift, place, at the goal, let go there). The same script places the cube
in the randomized MJX scene on MuJoCo Warp in joshua-lerobot's test_demos_gpu.py; MJX-JAX and Warp step that scene alike
(test_randomization.py)."""

from __future__ import annotations

from collections.abc import Callable, Generator, Iterator
from typing import Any

import numpy as np
import pytest

from joshua_mujoco import JAW_CLOSED, Phase, PickPlaceScript, make_vector_env

TASK = "so_arm100_pick_place"
# A stage has fired once its reward term exceeds this share of its weight.
STAGES = {"reach": 0.6, "grasp": 0.5, "lift": 0.5, "place": 0.8, "at_goal": 0.5, "released": 0.5}
WEIGHTS = {"reach": 1.0, "grasp": 0.5, "lift": 1.0, "place": 2.0, "at_goal": 5.0, "released": 3.0}


def drive(actions: Generator[Any, Any, None], measure: Callable[[], Any]) -> Iterator[tuple[str, Any]]:
    """Run a script: yield its (phase, action), then send it the joint positions `measure` reads after the step."""
    item = next(actions)
    while True:
        yield item
        try:
            item = actions.send(measure())
        except StopIteration:
            return


def first_steps(rewards: list[dict[str, float]]) -> dict[str, int]:
    """The first control step at which each stage's reward fired."""
    return {
        stage: next(step for step, terms in enumerate(rewards) if terms[stage] > share * WEIGHTS[stage])
        for stage, share in STAGES.items()
    }


def check_solved(rewards: list[dict[str, float]], success: float, phases: list[str]) -> None:
    fired = first_steps(rewards)
    assert list(fired.values()) == sorted(fired.values()), fired  # in the order of the task's stages
    assert phases[fired["grasp"]] in ("close", "lift") and phases[fired["at_goal"]] in ("lower", "release"), fired
    assert phases[fired["released"]] == "release" and rewards[-1]["released"] == WEIGHTS["released"], fired
    held = [terms["grasp"] for terms, phase in zip(rewards, phases, strict=True) if phase in ("carry", "lower")]
    assert min(held) == WEIGHTS["grasp"], held  # a grasp all the while the cube is carried and lowered
    assert success == 1.0


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("task", [TASK, "so101_pick_place"])
def test_the_script_solves_the_cpu_scene(task: str, seed: int) -> None:
    env = make_vector_env(task, 1, seed=seed, nthread=1)
    env.reset(seed=seed)
    simulation = env.simulation
    script = PickPlaceScript(simulation.model, simulation.task)
    cube = simulation.derived["xpos"][0, simulation.model.body("cube").id].copy()
    rewards, phases = [], []
    actions = script.actions(simulation.qpos[0].copy(), cube, simulation.commands["goal"][0])
    for phase, action in drive(actions, lambda: simulation.qpos[0].copy()):
        _, _, terminated, truncated, infos = env.step(action[None])
        assert not (terminated[0] or truncated[0])
        rewards.append({name: float(value[0]) for name, value in infos["reward_terms"].items()})
        phases.append(phase)
    check_solved(rewards, float(infos["metrics"]["success"][0]), phases)


def press(cube: np.ndarray, goal: np.ndarray) -> list[Phase]:
    """The closed jaw's tips come down on the cube's top and push on through it, as policies paid for any touch of
    both pads learnt to do (pressing the cube into the table and dragging it along)."""
    above, through = cube + [0.0, 0.0, 0.08], cube - [0.0, 0.0, 0.03]
    return [Phase("above", above, JAW_CLOSED, 40), Phase("press", through, JAW_CLOSED, 60)]


def test_pressing_on_the_cube_touches_both_pads_but_is_no_grasp() -> None:
    env = make_vector_env(TASK, 1, seed=0, nthread=1)
    env.reset(seed=0)
    simulation = env.simulation
    model = simulation.model
    touch = [model.sensor(name).adr[0] for name in ("gripper_touch_fixed", "gripper_touch_moving")]
    script = PickPlaceScript(model, simulation.task)
    cube = simulation.derived["xpos"][0, model.body("cube").id].copy()
    pressed, grasps = 0, 0
    actions = script.actions(simulation.qpos[0].copy(), cube, simulation.commands["goal"][0], plan=press)
    for _, action in drive(actions, lambda: simulation.qpos[0].copy()):
        _, _, _, _, infos = env.step(action[None])
        pressed += bool(np.all(simulation.derived["sensordata"][0, touch] > 0.05))
        grasps += infos["reward_terms"]["grasp"][0] > 0
    assert pressed >= 10 and grasps == 0, (pressed, grasps)
