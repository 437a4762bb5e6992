"""`joshua lerobot-units DATASET --units degrees|range [--calibration JSON]`: say which units a dataset's SO-100
values are in. lerobot does not record its follower's `use_degrees`, so a dataset recorded with
`use_degrees=False` would be read as degrees; this notes the units in the dataset's info.json, the record
every reader of the dataset (replay, validation, sysid, lerobot-export) converts with. A record already there
(joshua's writer makes one, with the mirror's offsets) is replaced only with `--overwrite`."""

from __future__ import annotations

import argparse
from pathlib import Path

from joshua_core.errors import UsageError
from joshua_core.interfaces import Command
from joshua_core.plugins import PluginHost
from joshua_lerobot.joints import add_units_arguments, units_from_arguments
from joshua_lerobot.reader import INFO, describe_units, record_units


class LeRobotUnitsCommand(Command):
    """Records the unit mode (and calibration) of a LeRobot dataset's joint values in its meta/info.json."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("dataset", type=Path, help="the LeRobot dataset folder (with meta/info.json)")
        add_units_arguments(parser, what="the dataset's")
        parser.add_argument("--overwrite", action="store_true", help="replace a units record the dataset already holds")

    def run(self, args: argparse.Namespace, plugins: PluginHost) -> int:
        units = units_from_arguments(args)
        if not (args.dataset / INFO).is_file():
            raise UsageError(f"{args.dataset}: not a LeRobot dataset folder (no {INFO})")
        changed = record_units(args.dataset, units, overwrite=args.overwrite)
        note = "" if changed else " (recorded already; unchanged)"
        print(f"{args.dataset / INFO}: {describe_units(units)}{note}")
        return 0
