"""Built-in terms that read a gripper's two touch pads: a grasp, and an object let go at its goal.

Pure functions of a `TermContext` like those of `joshua_core.tasks.terms`, on numpy and inside `jax.jit`;
`first` and `second` name touch sensors (`Touch`: its `sensordata` column and the site whose zone it reads).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from joshua_core.tasks.context import TermContext
from joshua_core.tasks.handles import Body, Sensor, Touch
from joshua_core.tasks.terms import body_command_within


def _both_above(ctx: TermContext, first_adr: int, second_adr: int, threshold: float) -> Any:
    """Where both sensor readings (at `sensordata` columns first_adr and second_adr) exceed `threshold`."""
    return (ctx.sensordata[:, first_adr] > threshold) & (ctx.sensordata[:, second_adr] > threshold)


def sensors_above(ctx: TermContext, first: Sensor, second: Sensor, threshold: float) -> Any:
    """1 where both sensors' first readings exceed `threshold` (two touch pads: a grasp), else 0."""
    return _both_above(ctx, first.adr, second.adr, threshold).astype(ctx.sensordata.dtype)


def body_pinched(
    ctx: TermContext, body: Body, first: Touch, second: Touch, threshold: float, radius: float = 0.02
) -> Any:
    """1 where two touch sensors (a gripper's pads) both read above `threshold` and the body's origin lies between
    their sites: its projection on the line joining them falls between them, within `radius` m of that line;
    else 0: a grasp of the body. The pads' tips pressing on the body's top touch both sensors too, with the body
    below the pads, not between them; a policy paid for that pressed the cube into the table."""
    touching = _both_above(ctx, first.adr, second.adr, threshold)
    first_site = ctx.site_xpos[:, first.site]
    axis, offset = ctx.site_xpos[:, second.site] - first_site, ctx.xpos[:, body.id] - first_site
    along = ctx.xp.sum(offset * axis, axis=-1) / ctx.xp.maximum(ctx.xp.sum(axis * axis, axis=-1), 1e-12)
    across = offset - along[:, None] * axis
    between = (along > 0) & (along < 1) & (ctx.xp.sum(across * across, axis=-1) < radius**2)
    return (touching & between).astype(ctx.xpos.dtype)


def body_released_at_command(
    ctx: TermContext, body: Body, name: str, radius: float, first: Touch, second: Touch, threshold: float
) -> Any:
    """1 where the body lies within `radius` m of a position command and the two touch sensors (a gripper's
    pads) do not both read above `threshold`: an object placed and let go (one pad may still rest on it), else
    0. Paid alike at the goal, held or not, nothing asked a policy to let go of a placed cube; the failed
    episodes of runs that plateaued at 70-89 % success had spent 80-160 steps at the goal before the cube left."""
    let_go = ~_both_above(ctx, first.adr, second.adr, threshold)
    return body_command_within(ctx, body, name, radius) * let_go.astype(ctx.xpos.dtype)


GRASP_TERMS: dict[str, Callable[..., Any]] = {
    function.__name__: function for function in (sensors_above, body_pinched, body_released_at_command)
}
