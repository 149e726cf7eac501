"""Command line: ``wbc walk``, ``wbc balance``, ``wbc sim``, ``wbc bench``, ``wbc plot``, ``wbc compile`` (also
``python -m wbc``).

Each run command (walk, balance, sim) prints a summary, and can write it as JSON (``--json``), a log (``--log``,
npz), plots (``--plot``, PNG), a self-contained meshcat HTML recording (``--out``), or show the motion live in
meshcat (``--live``, 127.0.0.1 only, held after the motion until Ctrl-C or ``--hold``).
Exit code 0 when the run met its acceptance criteria, 1 when it did not, 2 on bad input (a one-line error on
stderr, before any work: every value is checked first, :mod:`wbc.cli.validate`) or an output that could not be
written, 130 on Ctrl-C (SIGINT) and 143 on SIGTERM. Every file is written under a temporary name in its folder and
renamed when complete, a run's files together (:func:`wbc.cli.output.atomic_outputs`): an interrupted run leaves
the previous files as they were.
Angles on the command line are in degrees.

One module per command group (:mod:`wbc.cli.walk`, :mod:`~wbc.cli.plot`, :mod:`~wbc.cli.balance`,
:mod:`~wbc.cli.sim`, :mod:`~wbc.cli.campaign`, :mod:`~wbc.cli.bench`, :mod:`~wbc.cli.robots`, :mod:`~wbc.cli.ros2`,
:mod:`~wbc.cli.kernels` for ``wbc compile``), each with
``register(subparsers, add_outputs)``; what they share (summary printer, output writers, live viewer, progress)
is :mod:`wbc.cli.output`. The CLI is the top layer: nothing else in wbc imports it.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys

from wbc.exceptions import InvalidInputError, WbcError

__all__ = ["main", "build_parser", "deadline_misses", "leg_reach"]

# The command modules (and numpy, the solvers... behind them) load inside main(), where a Ctrl-C is handled and
# where the first run after an install says first that it compiles: the `wbc` script imports only this module.


def _commands() -> tuple:
    """The command modules, in the order of ``wbc --help``."""
    from wbc.cli import balance, bench, campaign, kernels, plot, robots, ros2, sim, walk

    return (walk, plot, balance, sim, campaign, bench, robots, ros2, kernels)


def __getattr__(name: str):
    if name == "COMMANDS":
        return _commands()
    if name == "deadline_misses":
        from wbc.cli.output import deadline_misses

        return deadline_misses
    if name == "leg_reach":
        from wbc.cli.walk import leg_reach

        return leg_reach
    raise AttributeError(f"module 'wbc.cli' has no attribute {name!r}")


#: ``wbc --help``'s description: the module docstring's first paragraph, without its reST markup.
DESCRIPTION = " ".join(__doc__.split("\n\n")[0].replace("``", "").split())


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error (``wbc walk: error: argument --steps: ...``), exit code 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The `wbc` argument parser with every sub-command (one module of :mod:`wbc.cli` per command group)."""
    from wbc import __version__

    parser = _Parser(prog="wbc", description=DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"wbc {__version__}")
    sub = _Commands(parser.add_subparsers(dest="command", required=True))
    from wbc.cli.output import add_outputs

    for module in _commands():
        module.register(sub, add_outputs)
    return parser


class _Commands:
    """The top-level sub-commands as handed to each command module's ``register``: argparse's ``add_parser``, with
    the parser's description defaulting to its one-line help (capitalised, with a full stop), so that every
    ``wbc X --help`` starts with a description."""

    def __init__(self, subparsers):
        self.subparsers = subparsers

    def add_parser(self, name: str, **kwargs) -> argparse.ArgumentParser:
        parser = self.subparsers.add_parser(name, **kwargs)
        text = kwargs.get("help")
        if not parser.description and text:
            parser.description = text[0].upper() + text[1:] + "."
        return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `wbc` console script. Returns the exit code: 0 passed, 1 acceptance failed, 2 bad input
    (a typed ``wbc.exceptions.WbcError``, printed on stderr as one line) or an output that could not be written,
    130 interrupted by Ctrl-C, 143 by SIGTERM (no traceback in either case; no partial file left)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    # A Ctrl-C while the modules load (seconds; longer on a first run) ends the process at once with 130: nothing has
    # been written yet, and raised inside an import a KeyboardInterrupt can end in a traceback or be swallowed by a
    # library's `except:`.
    run_sigint = None
    previous_unraisable = sys.unraisablehook
    try:
        default_sigint = signal.signal(signal.SIGINT, _exit_while_loading)
    except ValueError:  # not the main thread: leave SIGINT alone
        default_sigint = None
    try:
        _first_run_notice(argv)
        parser = build_parser()
        _preload(argv)
    finally:
        if default_sigint is not None:
            signal.signal(signal.SIGINT, default_sigint)
    args = parser.parse_args(argv)
    previous = None
    if default_sigint is signal.default_int_handler:  # a run's Ctrl-C: see on_sigint (ignored or the caller's: kept)
        from wbc.cli.output import clear_sigint, on_sigint, quiet_swallowed_interrupt

        clear_sigint()
        run_sigint = signal.signal(signal.SIGINT, on_sigint)
        previous_unraisable = sys.unraisablehook
        sys.unraisablehook = quiet_swallowed_interrupt
    from wbc.cli.output import Terminated, clear_sigint, on_sigterm, sigint_received, sigterm_received

    clear_sigint()
    try:
        previous = signal.signal(signal.SIGTERM, on_sigterm)
    except ValueError:  # not the main thread: leave SIGTERM alone
        pass
    try:
        check_args(args)
        code = int(args.func(args))
        if getattr(args, "live", False):
            from wbc.cli.output import hold_live

            hold_live(args.hold)
        sys.stdout.flush()
        return code
    except WbcError as exc:
        print(f"wbc {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, Terminated) as exc:
        return _stopped(args.command, isinstance(exc, Terminated) or sigterm_received())
    except SystemError as exc:
        # a Ctrl-C or SIGTERM whose handler ran inside a compiled kernel's call (numba's dispatcher returned a result
        # with the handler's exception set): CPython raises SystemError from it, or from what it broke
        chain, stop = exc, False
        while chain is not None and not stop:
            stop = isinstance(chain, (KeyboardInterrupt, Terminated))
            chain = chain.__cause__ or chain.__context__
        if not (stop or sigint_received() or sigterm_received()):
            raise
        return _stopped(args.command, sigterm_received() or isinstance(exc.__cause__, Terminated))
    except BrokenPipeError:  # `wbc ... | head`: the reader has gone; stop quietly
        _silence_stdout()
        return 0
    except OSError as exc:  # an output that passed the checks but could not be written (disk full...)
        print(f"wbc {args.command}: error: could not write {exc.filename or ''}: {exc.strerror or exc}",
              file=sys.stderr)
        return 2
    finally:
        from wbc.cli.output import close_live

        close_live()
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        if run_sigint is not None:
            signal.signal(signal.SIGINT, run_sigint)
            sys.unraisablehook = previous_unraisable


def _exit_while_loading(signum, frame) -> None:
    """SIGINT handler while the command modules load: say so and exit 130 (no output exists yet)."""
    os.write(2, b"wbc: interrupted (Ctrl-C) while loading\n")
    os._exit(130)


def _preload(argv: list[str]) -> None:
    """Import, while a Ctrl-C still exits at once, the third-party modules a run command loads later that catch
    BaseException around their optional imports (trimesh, via meshcat/pinocchio.visualize and wbc.sim.meshes):
    a Ctrl-C landing inside them would be swallowed and the run would go on. A `wbc walk` imports them only for
    a meshcat output (``--out``, ``--live``)."""
    if argv and argv[0] == "walk" and not any(a.startswith(("--out", "--live")) for a in argv):
        return
    if argv and argv[0] in ("walk", "balance", "sim") and not {"-h", "--help"} & set(argv):
        try:
            import trimesh  # noqa: F401
        except ImportError:
            pass


def _first_run_notice(argv: list[str]) -> None:
    """Before the parser imports the solvers: on the first run after an install (numba kernels not yet cached), say
    on stderr that loading and compiling takes a minute, for the commands that run a controller (on a terminal, not
    with --quiet or --help; later, :func:`wbc.cli.output.progress` says it to the other outputs)."""
    from wbc.cli.output import DYNAMICS_KERNELS, KINEMATIC_KERNELS, compile_notice

    if not argv or argv[0] not in ("walk", "balance", "sim", "bench", "campaign"):
        return
    if {"-q", "--quiet", "-h", "--help"} & set(argv) or not getattr(sys.stderr, "isatty", lambda: False)():
        return
    compile_notice(f"wbc {argv[0]}", DYNAMICS_KERNELS if argv[0] == "sim" else KINEMATIC_KERNELS)


def _silence_stdout() -> None:
    """Point stdout at /dev/null so that the interpreter's final flush does not raise BrokenPipeError again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass


def _stopped(command: str, terminated: bool) -> int:
    """The exit of a run stopped by a signal: one line on stderr; 143 for SIGTERM (``terminated``; also a SIGTERM
    swallowed by a C callback and raised as KeyboardInterrupt at the run's next tick), 130 for Ctrl-C."""
    if terminated:
        print(f"wbc {command}: terminated (SIGTERM)", file=sys.stderr)
        return 143
    print(f"wbc {command}: interrupted (Ctrl-C); no output written for the unfinished step", file=sys.stderr)
    return 130


def check_args(args) -> None:
    """Checks common to every command, before any run: the output paths (:func:`wbc.cli.validate.check_outputs`)
    and ``--hold``; then the command's own checks (``args.check(args)``, when the command sets one).

    Raises:
        InvalidInputError: an output path is refused (folder missing or not writable, a folder, a device, wrong
            suffix); ``--hold`` is negative or given without ``--live``; a command check fails.
    """
    from wbc.cli.validate import check_outputs

    check_outputs(args)
    hold = getattr(args, "hold", None)
    if hold is not None and not (hold >= 0 and hold != float("inf")):
        raise InvalidInputError(f"--hold must be a finite number of seconds >= 0, got {hold}")
    if hold is not None and not getattr(args, "live", False):
        raise InvalidInputError("--hold only applies with --live")
    if getattr(args, "live_start_now", False) and not getattr(args, "live", False):
        raise InvalidInputError("--live-start-now only applies with --live")
    check = getattr(args, "check", None)
    if check is not None:
        check(args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
