"""Command line: ``wbc walk``, ``wbc balance``, ``wbc sim``, ``wbc bench``, ``wbc plot`` (also ``python -m wbc``).

Each run command (walk, balance, sim) prints a summary, and can write it as JSON (``--json``), a log (``--log``,
npz), plots (``--plot``, PNG), a self-contained meshcat HTML recording (``--out``), or show the motion live in
meshcat (``--live``, 127.0.0.1 only, held after the motion until Ctrl-C or ``--hold``).
Exit code 0 when the run met its acceptance criteria, 1 when it did not, 2 on bad input.

One module per command group (:mod:`wbc.cli.walk`, :mod:`~wbc.cli.plot`, :mod:`~wbc.cli.balance`,
:mod:`~wbc.cli.sim`, :mod:`~wbc.cli.campaign`, :mod:`~wbc.cli.bench`, :mod:`~wbc.cli.robots`, :mod:`~wbc.cli.ros2`), each with
``register(subparsers, add_outputs)``; what they share (summary printer, output writers, live viewer, progress)
is :mod:`wbc.cli.output`. The CLI is the top layer: nothing else in wbc imports it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from wbc.cli import balance, bench, campaign, plot, robots, ros2, sim, walk
from wbc.cli.output import add_outputs, close_live, deadline_misses, hold_live
from wbc.cli.walk import leg_reach
from wbc.exceptions import InvalidInputError, WbcError

__all__ = ["main", "build_parser", "deadline_misses", "leg_reach"]

#: The command modules, in the order of ``wbc --help``.
COMMANDS = (walk, plot, balance, sim, campaign, bench, robots, ros2)


def build_parser() -> argparse.ArgumentParser:
    """The `wbc` argument parser with every sub-command (one module of :mod:`wbc.cli` per command group)."""
    from wbc import __version__

    parser = argparse.ArgumentParser(prog="wbc", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"wbc {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for module in COMMANDS:
        module.register(sub, add_outputs)
    helps = {a.dest: a.help for a in sub._choices_actions}
    for name, p in sub.choices.items():  # every `wbc X --help` starts with a description
        if not p.description and helps.get(name):
            p.description = helps[name][0].upper() + helps[name][1:] + "."
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `wbc` console script. Returns the exit code: 0 passed, 1 acceptance failed, 2 bad input
    (a typed ``wbc.exceptions.WbcError``, printed on stderr)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        check_args(args)
        code = int(args.func(args))
        if getattr(args, "live", False):
            hold_live(args.hold)
        return code
    except WbcError as exc:
        print(f"wbc {args.command}: error: {exc}", file=sys.stderr)
        return 2
    finally:
        close_live()


def check_args(args) -> None:
    """Checks common to every command, before any run.

    Raises:
        InvalidInputError: an output file's directory does not exist; ``--hold`` is negative or given without
            ``--live``.
    """
    for opt in ("json", "log", "out", "plot", "video"):
        path = getattr(args, opt, None)
        if path is not None:
            parent = Path(path).parent
            if not parent.is_dir():
                raise InvalidInputError(f"--{opt} {path}: directory {str(parent)!r} does not exist (create it first)")
    hold = getattr(args, "hold", None)
    if hold is not None and not (hold >= 0 and hold != float("inf")):
        raise InvalidInputError(f"--hold must be a finite number of seconds >= 0, got {hold}")
    if hold is not None and not getattr(args, "live", False):
        raise InvalidInputError("--hold only applies with --live")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
