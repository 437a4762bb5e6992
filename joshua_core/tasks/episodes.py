"""Episode bookkeeping of batched environments, written once for every backend in the array namespace `xp`.

After each step a backend calls `account_step`: it evaluates the task's rewards, terminations and
metrics on the step's `TermContext`, and keeps each environment's running return and per-term
sums. The rules, the same on numpy (joshua-mujoco) and inside `jax.jit` (joshua-mjx):

- A simulation that failed (a state that is non-finite or beyond any scene's bounds, see `nonfinite`, or a
  physics error) is terminated with zero reward and zero reward terms: its numbers never reach a return, and
  its episode's record says it failed (`Episode.failed`), so that trainers count blow-ups.
- `truncated` means the episode reached the task's episode length and was not terminated, so
  `terminated` and `truncated` are never both set; `done` is either.
- Where an episode ended, `Episode` holds its record (return, length, per-term sums, the task's
  metrics on its last step) and the running sums restart from zero for the next episode.

The backend itself restarts the simulations where `done` (autoreset) and counts `episode_step`.
"""

from __future__ import annotations

from typing import Any, NamedTuple

from joshua_core.errors import JoshuaError
from joshua_core.tasks.context import TermContext
from joshua_core.tasks.task import Task

# An episode's record flattened beside other values (a NUMPY environment's "episode" info, a trainer's logged
# iteration) names each reward term's sum REWARD_PREFIX + term and each task metric METRIC_PREFIX + name.
REWARD_PREFIX = "reward/"
METRIC_PREFIX = "metrics/"
# A state beyond these bounds has blown up as surely as a non-finite one (a cube flung 1e7 m by a randomized
# contact, a joint spun at 1e6 rad/s), long before it turns non-finite: no scene is 1 km wide, no joint turns at
# 1e4 rad/s (a hobby servo: about 10)
MAX_POSITION = 1e3  # of any qpos entry (metres or radians)
MAX_SPEED = 1e4  # of any qvel entry (m/s or rad/s)
# Where trainers log how many of the episodes that ended blew up (their record's `failed`).
FAILED_EPISODES = "failed_episodes"
# Training stops where more than this share of at least MIN_ENDED_EPISODES ended episodes blew up: a policy learns
# nothing but blow-ups from them. A share below it is counted (FAILED_EPISODES) and training goes on.
MAX_FAILED_SHARE = 0.5
MIN_ENDED_EPISODES = 16


class SimulationsBlewUp(JoshuaError):
    """Most simulations of a stretch of training blew up: training stopped before learning from them."""


def check_blow_ups(ended: float, failed: float, where: str) -> None:
    """Raise SimulationsBlewUp when more than MAX_FAILED_SHARE of at least MIN_ENDED_EPISODES episodes that ended
    (those of `where`, e.g. "iteration 3") blew up; the message names the likely causes."""
    if ended >= MIN_ENDED_EPISODES and failed > MAX_FAILED_SHARE * ended:
        raise SimulationsBlewUp(
            f"{failed:.0f} of the {ended:.0f} episodes that ended in {where} blew up (a state not finite, or beyond "
            f"{MAX_POSITION:g} or {MAX_SPEED:g} per second); the last checkpoint before it is kept. Likely causes: a "
            "timestep too large for the model (its option timestep), masses or gains in the model far off, or "
            "randomization ranges too wide (task_config.events: masses, gains, frictions)"
        )


class Episode(NamedTuple):
    """The episodes that ended on a step; entries are valid where `done`."""

    done: Any  # (N,) bool
    return_: Any  # (N,) undiscounted return
    length: Any  # (N,) steps
    reward_terms: dict[str, Any]  # per reward term, its weighted sum over the episode
    metrics: dict[str, Any]  # the task's metrics on the episode's last step
    failed: Any  # (N,) bool: the episode ended because its simulation failed (blew up)

    @classmethod
    def none(cls, xp: Any, task: Task, num_envs: int, dtype: Any) -> Episode:
        """The record of a step on which no episode ended (after a reset)."""
        zeros = xp.zeros(num_envs, dtype)
        return cls(
            done=xp.zeros(num_envs, bool),
            return_=zeros,
            length=xp.zeros(num_envs, xp.int32),
            reward_terms={term.name: zeros for term in task.reward_terms},
            metrics={term.name: zeros for term in task.metric_terms},
            failed=xp.zeros(num_envs, bool),
        )


class EpisodeSums(NamedTuple):
    """The current episodes' return and per-term reward sums so far."""

    return_: Any  # (N,)
    reward_terms: dict[str, Any]  # per reward term, (N,)

    @classmethod
    def zeros(cls, xp: Any, task: Task, num_envs: int, dtype: Any) -> EpisodeSums:
        zeros = xp.zeros(num_envs, dtype)
        return cls(zeros, {term.name: zeros for term in task.reward_terms})

    def restart(self, xp: Any, mask: Any) -> EpisodeSums:
        """These sums with the environments where `mask` is set back at zero."""
        return EpisodeSums(
            xp.where(mask, 0.0, self.return_),
            {name: xp.where(mask, 0.0, value) for name, value in self.reward_terms.items()},
        )


class StepOutcome(NamedTuple):
    """What one step did, by the rules of the module docstring."""

    reward: Any  # (N,) in `dtype`
    reward_terms: dict[str, Any]  # per reward term, its weighted value on this step, in `dtype`
    terminated: Any  # (N,) bool
    truncated: Any  # (N,) bool
    metrics: dict[str, Any]  # the task's metrics after this step, in `dtype`
    episode: Episode  # the episodes that ended on this step
    sums: EpisodeSums  # the running sums to carry on (zero where an episode ended)


def nonfinite(xp: Any, qpos: Any, qvel: Any) -> Any:
    """(N,) bool: the simulations that blew up: positions or velocities no longer finite, or beyond MAX_POSITION
    or MAX_SPEED."""
    return ~((xp.abs(qpos) <= MAX_POSITION).all(axis=1) & (xp.abs(qvel) <= MAX_SPEED).all(axis=1))


def account_step(task: Task, ctx: TermContext, failed: Any, sums: EpisodeSums, dtype: Any) -> StepOutcome:
    """Evaluate the task on the state after a step (`ctx`, with `episode_step` already counting this step)
    and do the episode bookkeeping; `failed` (N,) marks the simulations that failed on this step."""
    xp = ctx.xp
    total, weighted = task.rewards(ctx)
    reward = xp.where(failed, 0.0, total).astype(dtype)
    reward_terms = {name: xp.where(failed, 0.0, value).astype(dtype) for name, value in weighted.items()}
    terminated = task.terminated(ctx) | failed
    truncated = (ctx.episode_step >= task.episode_length) & ~terminated
    done = terminated | truncated
    ended = EpisodeSums(
        sums.return_ + reward, {name: sums.reward_terms[name] + value for name, value in reward_terms.items()}
    )
    metrics = {name: value.astype(dtype) for name, value in task.metrics(ctx).items()}
    episode = Episode(done, ended.return_, ctx.episode_step, ended.reward_terms, metrics, failed & done)
    return StepOutcome(reward, reward_terms, terminated, truncated, metrics, episode, ended.restart(xp, done))
