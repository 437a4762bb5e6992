"""Where a `trajectory_path` is read: a CSV here, any other source (a LeRobot dataset folder) by the
`TrajectoryReader` a plugin registers. The one entry for every consumer (replay, validation, sysid, exporters);
above the plugin host, since it asks the run's host for its readers.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from joshua_core.catalog import provided
from joshua_core.interfaces import TrajectoryReader
from joshua_core.kinds import Kind
from joshua_core.trajectory import Trajectory, TrajectoryError, read_trajectory

if TYPE_CHECKING:
    from joshua_core.plugins import PluginHost


def load_trajectory(
    path: str | Path,
    joints: Mapping[str, tuple[float, float]],
    *,
    episode: int = 0,
    plugins: PluginHost,
) -> Trajectory:
    """The trajectory at `path` for a model whose scalar joints are `joints` (name -> (low, high) range;
    unlimited: -inf, inf): a CSV file read here, or a folder (e.g. a LeRobot dataset) read by the first
    registered `TrajectoryReader` of `plugins` that accepts it. `episode` picks
    one episode of a source that holds several; a CSV holds one."""
    source = Path(path)
    if not source.is_dir():
        if episode:
            raise TrajectoryError(f"{source}: a trajectory CSV holds one episode; episode {episode} does not exist")
        return read_trajectory(source, list(joints))
    names = plugins.names(Kind.TRAJECTORY_READER)
    for name in names:
        reader = plugins.create(Kind.TRAJECTORY_READER, name, TrajectoryReader)
        if reader.accepts(source):
            return reader.read(source, joints, episode=episode)
    absent = {name: dist for name, dist in provided(Kind.TRAJECTORY_READER).items() if name not in names}
    hint = "".join(f"; the reader '{name}' comes with {dist}: pip install {dist}" for name, dist in absent.items())
    raise TrajectoryError(
        f"{source}: a folder, and no installed trajectory reader takes it (installed: {', '.join(names) or 'none'})"
        + hint
    )
