"""`joshua usd inspect FILE`, `joshua usd export MODEL OUT.usd` and `joshua usd eval RUN --physics MUJOCO,PHYSX`."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from joshua_core.interfaces import Command
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path


class UsdCommand(Command):
    """What the importer understands of a USD robot, MJCF -> USD for Isaac, and a policy on each physics."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
        inspect = actions.add_parser(
            "inspect",
            help="print the bodies, joints (limits in radians and degrees), drives in SI units, "
            "colliders, masses and warnings the importer reads from a USD file, and every authored physics "
            "attribute it did not use",
        )
        inspect.add_argument("file", type=Path, help="a .usd/.usda/.usdc/.usdz stage")
        export = actions.add_parser("export", help="write a MuJoCo model as a UsdPhysics articulation Isaac loads")
        export.add_argument("model", type=Path, help="an MJCF model (.xml), e.g. so_arm100/so_arm100.xml")
        export.add_argument("out", type=Path, help="the USD file to write (.usd, .usda or .usdc)")
        from joshua_usd import sim2sim

        sim2sim.add_arguments(
            actions.add_parser(
                "eval",
                help="roll one trained policy out on each physics of the usd backend (MuJoCo, PhysX): "
                "mean return and success with 95 %% intervals side by side",
            )
        )

    def run(self, args: argparse.Namespace, plugins: PluginHost) -> int:
        if args.action == "eval":
            from joshua_usd import sim2sim

            return sim2sim.run(args, plugins)
        if args.action == "inspect":
            from joshua_usd.inspect import describe

            print(describe(resolve_data_path(args.file, what="USD")))
            return 0
        from pxr import Usd

        from joshua_usd import physx_schema
        from joshua_usd.exporter import export_model

        written = export_model(resolve_data_path(args.model), args.out)
        if physx_schema.registered():  # the exporter's own PhysX attributes, checked against the PhysX schemas
            for problem in physx_schema.check_stage(Usd.Stage.Open(str(written))):
                print(f"joshua: warning: {written}: {problem}", file=sys.stderr)
        print(f"wrote {written}")
        return 0
