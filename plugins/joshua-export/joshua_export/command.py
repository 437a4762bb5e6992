"""`joshua export RUN`: a trained run's policy as policy.onnx and its contract policy.json.

The trainer that wrote the run (config.json's "trainer") describes its policy (`Trainer.export_policy`);
the task is rebuilt on its model as in training, so the contract's terms and slices are the task's own.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from joshua_core.atomic import atomic_write_bytes, atomic_write_json
from joshua_core.errors import UsageError
from joshua_core.interfaces import Command
from joshua_core.outputs import check_replaceable, output_folder
from joshua_core.resources import resolve_data_path
from joshua_core.run_context import RunContext
from joshua_core.runs import add_checkpoint_arguments, read_run_config, resolve_checkpoint
from joshua_export.contract import CONTRACT_FILE, ONNX_FILE, make_contract
from joshua_export.graph import policy_graph
from joshua_export.observer import Observer

if TYPE_CHECKING:
    from joshua_core.plugins import PluginHost


class ExportCommand(Command):
    """`joshua export RUN [--out DIR [--overwrite]]`: write policy.onnx and policy.json into RUN's checkpoint folder,
    or as the folder DIR, written whole; an existing DIR is only replaced when joshua wrote it."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        add_checkpoint_arguments(parser)
        parser.add_argument(
            "--out", type=Path, help="a folder of its own to write (default: into the checkpoint folder)"
        )
        parser.add_argument("--overwrite", action="store_true", help="replace the --out folder when joshua wrote it")

    def run(self, args: argparse.Namespace, plugins: PluginHost) -> int:
        if args.out is not None:
            check_replaceable(args.out, overwrite=args.overwrite, option="--out")
        checkpoint = resolve_checkpoint(args.run)
        trainer = plugins.trainer(read_run_config(checkpoint)["trainer"])
        exported = trainer.export_policy(
            checkpoint, context=RunContext(plugins, checkpoint), trust_checkpoint=args.trust_checkpoint
        )
        training = exported.training
        if not training.task:
            raise UsageError(f"run {checkpoint} names no task: there is no observation contract to export")
        model_path = resolve_data_path(training.model_path) if training.model_path else None
        task_config = training.task_config if training.HasField("task_config") else None
        observer = Observer.load(training.task, model_path, plugins, task_config)
        onnx_bytes = policy_graph(exported.policy, name=f"{training.task}_{exported.trainer}").SerializeToString()
        contract = make_contract(exported, observer, onnx_bytes)
        out = args.out or checkpoint
        if args.out is None:
            atomic_write_bytes(out / ONNX_FILE, onnx_bytes)
            atomic_write_json(out / CONTRACT_FILE, contract)  # last: a contract always finds its graph
        else:
            with output_folder(out, overwrite=args.overwrite, option="--out") as folder:
                atomic_write_bytes(folder / ONNX_FILE, onnx_bytes)
                atomic_write_json(folder / CONTRACT_FILE, contract)
        print(f"exported {checkpoint} ({exported.trainer}, task {training.task}, {contract['control_hz']:g} Hz)")
        print(f"policy: {out / ONNX_FILE}\ncontract: {out / CONTRACT_FILE}")
        return 0
