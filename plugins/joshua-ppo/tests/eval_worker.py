"""`joshua eval` with distributed_worker.py's plugins: `python eval_worker.py RUN [eval's options]`.

The test task (`slider_reach`) is no entry point, so the `joshua` command cannot evaluate its runs; this runs
the command's own `EvalCommand` with the test task's plugin host, reporting as the `joshua` command does.
"""

from __future__ import annotations

import argparse
import sys

from distributed_worker import plugins

from joshua_core.evaluation import EvalCommand
from joshua_core.interrupts import reported


def main(argv: list[str]) -> int:
    command = EvalCommand()
    parser = argparse.ArgumentParser(prog="joshua eval")
    command.add_arguments(parser)
    args = parser.parse_args(argv)
    return reported(lambda: command.run(args, plugins()))


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
