"""``wbc plot LOG.npz``: plot a run's npz log (written with ``--log``) to a PNG."""

from __future__ import annotations

from pathlib import Path

__all__ = ["register", "cmd_plot"]


def check_plot_args(args) -> None:
    """``wbc plot`` checks before any work: the log is a readable wbc npz log, the PNG path is writable.

    Raises:
        InvalidInputError: naming the log or ``--out``.
    """
    from wbc.cli.validate import output_path
    from wbc.viz.plots import load_log

    import zipfile

    from wbc.exceptions import InvalidInputError

    args.out = output_path("--out", args.out or Path(args.log_file).with_suffix(".png"), ".png")
    path = Path(args.log_file)
    if path.is_file() and not zipfile.is_zipfile(path):  # an npz is a zip archive of .npy arrays
        raise InvalidInputError(f"{str(path)!r} is not a readable npz log (not a zip archive of arrays; a run writes "
                                "one with --log FILE.npz)")
    args.log = load_log(path)


def cmd_plot(args) -> int:
    """`wbc plot LOG.npz`: plot a log written with --log; exit code 0, 2 on a bad log or output path."""
    from wbc.cli.output import atomic_output
    from wbc.viz.plots import plot_log

    with atomic_output(args.out) as tmp:
        plot_log(args.log, tmp)
    print(f"plots written to {args.out}")
    return 0


def register(sub, add_outputs=None) -> None:
    """Add the ``plot`` sub-command to ``wbc``'s sub-parsers (``add_outputs`` is not used)."""
    plot = sub.add_parser("plot", help="plot a run's npz log (written with --log) to a PNG",
                          description="Plot a log written by `wbc walk/balance/sim --log FILE.npz`: CoM, ZMP/CoP "
                                      "and DCM vs time with support bands, top view, joints vs limits, contact "
                                      "forces (sim), tick-time histogram.")
    plot.add_argument("log_file", type=Path, metavar="LOG.npz", help="npz log of a run")
    plot.add_argument("--out", type=Path, metavar="PNG", help="output PNG (default: LOG with .png)")
    plot.set_defaults(func=cmd_plot, check=check_plot_args, output_suffixes={"out": ".png"})
