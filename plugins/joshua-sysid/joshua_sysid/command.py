"""`joshua sysid RECORDING...`: fit the model's servo and joint parameters to recordings of commanded targets
and measured positions; write the calibrated model, report.json and a tracking plot into a fresh run folder."""

from __future__ import annotations

import argparse
import difflib
import shutil
import sys
from pathlib import Path

from joshua_core.cli import writable_folder
from joshua_core.defaults import DEFAULT_OUTPUT_DIR
from joshua_core.errors import UsageError
from joshua_core.interfaces import Command
from joshua_core.plugins import PluginHost
from joshua_core.resources import resolve_data_path
from joshua_core.runs import LOCK_FILE, check_run_name, create_run
from joshua_mujoco import read_spec
from joshua_sysid import fit, recordings, report
from joshua_sysid.calibrated import calibrated_model_name
from joshua_sysid.fit import KINDS

DEFAULT_MODEL = "so_arm100/so_arm100.xml"  # the arm alone: calibration motions touch nothing
DEFAULT_MAX_ITERS = 50
RUN_STEM = "sysid"


class SysidCommand(Command):
    """Identifies kp, damping, armature and friction loss per servo with mujoco.sysid."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument(
            "recordings",
            nargs="+",
            type=Path,
            help="trajectory CSVs with a '<joint>.target' column beside each joint column, or LeRobot dataset folders "
            "(see docs/sim-to-real.md)",
        )
        parser.add_argument("--model", default=DEFAULT_MODEL, help=f"the model to calibrate (default {DEFAULT_MODEL})")
        parser.add_argument(
            "--fit",
            default=",".join(KINDS),
            metavar="KINDS",
            help=f"comma-separated parameters to fit per servo (default all: {','.join(KINDS)})",
        )
        parser.add_argument(
            "--max-iters",
            type=int,
            default=DEFAULT_MAX_ITERS,
            help=f"optimizer iterations at most (default {DEFAULT_MAX_ITERS})",
        )
        parser.add_argument(
            "--output-dir",
            default=DEFAULT_OUTPUT_DIR,
            help=f"where the run folder goes (default {DEFAULT_OUTPUT_DIR})",
        )
        parser.add_argument(
            "--episode",
            type=int,
            default=0,
            help="the episode of each dataset folder (e.g. LeRobot's) to fit (default 0); CSVs have one",
        )
        parser.add_argument("--run-name", help=f"the run folder's name (default {RUN_STEM}_<date>-<time>)")

    def run(self, args: argparse.Namespace, plugins: PluginHost) -> int:
        if args.run_name is not None:
            check_run_name(args.run_name, "--run-name")  # before the fit, which may take minutes
        kinds = _parse_kinds(args.fit)
        if args.episode < 0:
            raise UsageError(f"--episode must be at least 0 (got {args.episode})")
        if args.max_iters < 1:
            raise UsageError(f"--max-iters must be at least 1 (got {args.max_iters})")
        model_path = resolve_data_path(args.model)
        spec = read_spec(model_path, plugins)
        model = spec.copy().compile()
        servos = recordings.model_servos(model, model_path)
        loaded = recordings.load_recordings(args.recordings, model, servos, plugins, episode=args.episode)
        root = writable_folder(args.output_dir, "--output-dir")
        # claimed before the fit, which may take minutes: a name in use is refused at once, a folder left holding
        # only the lock of a run that died is taken over, and a fit that fails leaves no folder (RunFolder)
        with create_run(root, args.run_name, stem=RUN_STEM, options="--run-name") as run:
            result = fit.fit(spec, servos, loaded, kinds, args.max_iters)
            try:
                model_file = report.write_model(spec, result, servos, run.path, calibrated_model_name(model_path))
                report.write_plot(result, servos, run.path / report.PLOT_FILE)
                outputs = {"model": model_file.name, "plot": report.PLOT_FILE}
                document = report.report_document(result, servos, loaded, model_path, outputs)
                report_file = report.write_report(document, run.path)
            except BaseException:
                _empty(run.path)  # then the run folder, holding only its lock, goes too: no half-made run
                raise
        print(report.table(result, servos))
        tracking = document["tracking_rms"]
        print(
            f"tracking RMS {tracking['overall_before']:.3e} -> {tracking['overall_after']:.3e} rad after "
            f"{result.iterations} iterations in {result.seconds:.1f} s"
        )
        print(f"calibrated model: {model_file}\nreport: {report_file}\nplot: {run.path / report.PLOT_FILE}")
        warning = fit.quality_warning(result)
        if warning:
            print(f"joshua: warning: {warning}", file=sys.stderr)
        return 0


def _parse_kinds(text: str) -> list[str]:
    """The --fit list, checked against the known kinds (close matches suggested)."""
    kinds = [kind.strip() for kind in text.split(",") if kind.strip()]
    known = KINDS
    for kind in kinds:
        if kind not in known:
            close = difflib.get_close_matches(kind, known, n=1)
            hint = f" (did you mean {close[0]}?)" if close else ""
            raise UsageError(f"--fit: unknown parameter '{kind}'{hint}; known: {', '.join(known)}")
    if not kinds:
        raise UsageError(f"--fit names no parameter; known: {', '.join(known)}")
    return [kind for kind in known if kind in kinds]


def _empty(folder: Path) -> None:
    """Remove what a failed fit wrote into its run folder, all but the lock."""
    for path in folder.iterdir():
        if path.name == LOCK_FILE:
            continue
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)
