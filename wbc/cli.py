"""Command line: ``wbc walk``, ``wbc balance``, ``wbc sim``, ``wbc bench``, ``wbc plot`` (also ``python -m wbc``).

Each run command (walk, balance, sim) prints a summary, and can write it as JSON (``--json``), a log (``--log``,
npz), plots (``--plot``, PNG), a self-contained meshcat HTML recording (``--out``), or show the motion live in
meshcat (``--live``, 127.0.0.1 only, held after the motion until Ctrl-C or ``--hold``).
Exit code 0 when the run met its acceptance criteria, 1 when it did not, 2 on bad input.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from wbc.exceptions import WbcError

__all__ = ["main"]


def _add_outputs(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", type=Path, metavar="FILE", help="write the summary as JSON")
    p.add_argument("--log", type=Path, metavar="FILE", help="write the time series as npz")
    p.add_argument("--out", type=Path, metavar="FILE", help="write a self-contained meshcat HTML recording")
    p.add_argument("--live", action="store_true",
                   help="show the motion live in meshcat (127.0.0.1 only, paced to real time); the viewer stays up "
                        "after the motion until Ctrl-C or --hold")
    p.add_argument("--plot", type=Path, metavar="PNG",
                   help="write plots of the run (CoM/ZMP/DCM, top view, joint limits, contact forces, tick times)")
    p.add_argument("--quiet", action="store_true", help="no progress bar (it is shown on a terminal for runs > 2 s)")
    p.add_argument("--hold", type=float, metavar="SECONDS", default=None,
                   help="with --live: keep the viewer up this long after the motion (default: until Ctrl-C)")


def _print_summary(summary: dict, indent: str = "  ") -> None:
    for key, value in summary.items():
        if isinstance(value, dict):
            inner = ", ".join(f"{k} {_fmt(v)}" for k, v in value.items())
            print(f"{indent}{key:28s} {inner}")
        else:
            print(f"{indent}{key:28s} {_fmt(value)}")


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def _write_outputs(args, summary: dict, run, robot, overlays: dict | None = None, scene: dict | None = None) -> None:
    if args.json:
        args.json.write_text(json.dumps(summary, indent=2) + "\n")
        print(f"summary written to {args.json}")
    if args.log:
        run.save(args.log)
        print(f"log written to {args.log}")
    if getattr(args, "plot", None):
        _write_plot(args.plot, run)
    if args.out:
        from wbc.viz import record_html

        extra = {} if scene is None else {k: scene[k] for k in ("polygons", "paths", "outlines") if k in scene}
        path = record_html(robot, run.t, run.q, args.out, overlays=overlays, **extra)
        print(f"meshcat recording written to {path} ({path.stat().st_size / 1e6:.1f} MB)")


def _write_plot(path, run) -> None:
    """Plot a run (anything with ``save(file)`` writing an npz log) to the PNG ``path``."""
    import io

    import numpy as np

    from wbc.viz.plots import plot_log

    buf = io.BytesIO()
    run.save(buf)
    buf.seek(0)
    with np.load(buf, allow_pickle=False) as z:
        log = {k: z[k] for k in z.files}
    plot_log(log, path)
    print(f"plots written to {path}")


def cmd_plot(args) -> int:
    """`wbc plot LOG.npz`: plot a log written with --log; exit code 0, 2 on a bad log or output path."""
    from wbc.viz.plots import plot_log

    out = args.out or Path(args.log_file).with_suffix(".png")
    plot_log(args.log_file, out)
    print(f"plots written to {out}")
    return 0


_LIVE_VIEWERS: list = []  # viewers opened by _live, closed by main() after the hold


class _HeldViewer:
    """A LiveViewer whose ``close()`` (called by the commands when the motion ends) is deferred to main()."""

    def __init__(self, viewer):
        self._viewer = viewer

    def __getattr__(self, name):
        return getattr(self._viewer, name)

    def close(self) -> None:
        pass


def _live(robot):
    """(viewer, pacer) for --live: a meshcat server on 127.0.0.1 (every port) and a real-time pacer.

    The URL is printed before the motion starts; main() keeps the viewer up after the command until Ctrl-C or
    ``--hold`` seconds, then closes it.
    """
    from wbc.viz import LiveViewer, RealTimePacer

    viewer = LiveViewer(robot)
    _LIVE_VIEWERS.append(viewer)
    print(f"meshcat viewer: {viewer.url} (open it in a browser)", flush=True)
    return _HeldViewer(viewer), RealTimePacer()


def _progress(args, total: float | None, viewer=None, desc: str = ""):
    """Wrap ``viewer`` (None or a live viewer) in a progress bar on stderr, unless --quiet or not a terminal."""
    from wbc.viz.progress import ProgressViewer

    return ProgressViewer(total, viewer, desc=desc, enabled=False if getattr(args, "quiet", False) else None)


def _hold_live(seconds: float | None) -> None:
    """Keep the live viewers up for ``seconds`` (None: until Ctrl-C)."""
    import time

    if not _LIVE_VIEWERS:
        return
    urls = ", ".join(v.url for v in _LIVE_VIEWERS)
    bound = "Ctrl-C" if seconds is None else f"{seconds:g} s or Ctrl-C"
    print(f"motion done; meshcat viewer stays up at {urls} (until {bound})", flush=True)
    try:
        if seconds is None:
            while True:
                time.sleep(3600)
        time.sleep(max(0.0, seconds))
    except KeyboardInterrupt:
        pass


def _close_live() -> None:
    while _LIVE_VIEWERS:
        _LIVE_VIEWERS.pop().close()


def deadline_misses(tick_time, dt: float) -> int:
    """Number of ticks whose controller time (s) exceeded the control period ``dt`` (s)."""
    import numpy as np

    return int(np.count_nonzero(np.asarray(tick_time, dtype=float) > dt))


MIN_STEPS = 2  # one step forward and the closing step


def leg_reach(robot) -> float:
    """Largest fore-aft distance (m) between the two soles in double support that the legs can span.

    Geometric bound: leg length l (sum of the distances between the joint origins from the hip to the sole
    frame, ``q_ref``) and hip height h above the sole at ``q_ref``; with the hips above the mid-point the
    soles are at most ``2 sqrt(l^2 - h^2)`` apart. A step moves the feet mid-point by the step length, so
    the soles are one step length apart in double support.
    """
    import numpy as np
    import pinocchio as pin

    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, robot.q_ref)
    fid = robot.frame_id(robot.left_sole)
    chain = []
    j = model.frames[fid].parentJoint
    while j > 0 and model.joints[j].nq != 7:  # up to the joint under the free flyer (the hip)
        chain.append(j)
        j = model.parents[j]
    points = [data.oMf[fid].translation] + [data.oMi[j].translation for j in chain]
    length = float(sum(np.linalg.norm(b - a) for a, b in zip(points[:-1], points[1:])))
    height = float(points[-1][2] - points[0][2])
    return 2.0 * float(np.sqrt(max(length**2 - height**2, 0.0)))


def _check_walk_args(args, robot) -> None:
    """Refuse walk parameters that cannot be walked, before any run.

    Raises:
        InvalidInputError: ``--steps`` < 2, ``--step-length`` negative or beyond :func:`leg_reach`.
    """
    from wbc.exceptions import InvalidInputError

    if args.steps < MIN_STEPS:
        raise InvalidInputError(f"--steps {args.steps}: a walk needs at least {MIN_STEPS} steps (valid: steps >= "
                                f"{MIN_STEPS}; the last step brings the feet side by side)")
    if args.step_length is not None:
        reach = leg_reach(robot)
        if not (0.0 <= args.step_length <= reach):
            raise InvalidInputError(f"--step-length {args.step_length} m is beyond the reach of {robot.name}'s legs "
                                    f"(valid: 0 <= step length <= {reach:.3f} m)")


def cmd_walk(args) -> int:
    """`wbc walk`: plan, walk, print and write the outputs; exit code 0 passed, 1 failed criteria."""
    from wbc.robot import load_robot
    from wbc.scenarios.walk import plan_default_walk, run_walk, walk_summary
    from wbc.scenarios.acceptance import walk_passes

    from wbc.robot_cli import robot_from_args

    robot = robot_from_args(args) if hasattr(args, "left_sole") else load_robot(args.robot)
    _check_walk_args(args, robot)
    plan = plan_default_walk(robot, n_steps=args.steps, step_length=args.step_length,
                             step_width=args.step_width, turn=args.turn, dt=args.dt)
    viewer = pacer = None
    if args.live:
        from wbc.viz.live_overlays import LiveOverlays

        viewer, pacer = _live(robot)
        viewer.set_overlays(LiveOverlays(robot, plan))  # planned footsteps, ZMP and DCM too
    viewer = _progress(args, float(plan.t[-1]), viewer, desc="wbc walk")
    ros2_pub = None
    if args.ros2 or args.bag is not None:
        from wbc.ros2.cli import attach, finish

        viewer_or_pub, ros2_pub = attach(args, robot, viewer, args.dt)
    try:
        run = run_walk(robot, plan, solver=args.solver, viewer=viewer_or_pub if ros2_pub else viewer, pacer=pacer)
    finally:
        if viewer is not None:
            viewer.close()
        if ros2_pub is not None:
            finish(ros2_pub)
    summary = walk_summary(robot, plan, run)
    summary["solver"] = args.solver
    summary["deadline_misses"] = deadline_misses(run.tick_time, args.dt)
    passed, failures = walk_passes(summary)
    summary["passed"] = passed
    summary["failed_criteria"] = failures
    print(f"wbc walk: {robot.name}, {summary['steps']} steps, {summary['ticks']} ticks at "
          f"{1 / args.dt:.0f} Hz, solver {args.solver}")
    _print_summary(summary)
    from wbc.viz.overlays import walk_overlays

    scene = walk_overlays(robot, plan, run)
    _write_outputs(args, summary, run, robot, overlays=scene["points"], scene=scene)
    return 0 if passed else 1


def build_parser() -> argparse.ArgumentParser:
    """The `wbc` argument parser with every sub-command (walk here; balance, sim, bench from their modules)."""
    from wbc.qp import DEFAULT_SOLVER, available_solvers

    from wbc import __version__

    parser = argparse.ArgumentParser(prog="wbc", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"wbc {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    walk = sub.add_parser("walk", help="walk a humanoid under the 500 Hz kinematic QP controller",
                          description="Plan a straight (or turning) walk from the robot's reference stance and track "
                                      "it with the 500 Hz kinematic QP; prints a summary with acceptance criteria.")
    walk.add_argument("--robot", default="talos", help="catalog name or URDF path (default talos)")
    walk.add_argument("--steps", type=int, default=8,
                      help=f"number of steps, >= {MIN_STEPS}, the last one bringing the feet side by side: the feet "
                           "advance (steps - 1) x step length (default 8)")
    walk.add_argument("--step-length", type=float, default=None,
                      help="m, feet advance per step, at most the leg's reach (default: the robot's, talos 0.15)")
    walk.add_argument("--step-width", type=float, default=None, help="m (default: current feet distance)")
    walk.add_argument("--turn", type=float, default=0.0, help="yaw change per step, rad (default 0)")
    walk.add_argument("--solver", default=DEFAULT_SOLVER, choices=available_solvers(), help=f"QP backend (default {DEFAULT_SOLVER})")
    walk.add_argument("--dt", type=float, default=0.002, help="control period, s (default 0.002)")
    _add_outputs(walk)
    from wbc.robot_cli import add_robot_options
    from wbc.ros2.cli import add_run_options

    add_robot_options(walk)
    add_run_options(walk)
    walk.set_defaults(func=cmd_walk)

    plot = sub.add_parser("plot", help="plot a run's npz log (written with --log) to a PNG",
                          description="Plot a log written by `wbc walk/balance/sim --log FILE.npz`: CoM, ZMP/CoP "
                                      "and DCM vs time with support bands, top view, joints vs limits, contact "
                                      "forces (sim), tick-time histogram.")
    plot.add_argument("log_file", type=Path, metavar="LOG.npz", help="npz log of a run")
    plot.add_argument("--out", type=Path, metavar="PNG", help="output PNG (default: LOG with .png)")
    plot.set_defaults(func=cmd_plot)

    for register in _extra_commands():
        register(sub, _add_outputs)
    helps = {a.dest: a.help for a in sub._choices_actions}
    for name, p in sub.choices.items():  # every `wbc X --help` starts with a description
        if not p.description and helps.get(name):
            p.description = helps[name][0].upper() + helps[name][1:] + "."
    return parser


def _extra_commands():
    """Sub-commands defined next to their scenarios (each module exposes ``register(subparsers, add_outputs)``)."""
    import importlib

    out = []
    for module in ("wbc.scenarios.balance_cli", "wbc.sim.cli", "wbc.bench.cli", "wbc.robot_cli", "wbc.ros2.cli"):
        try:
            out.append(importlib.import_module(module).register)
        except ModuleNotFoundError as exc:
            if exc.name != module:
                raise
    return out


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `wbc` console script. Returns the exit code: 0 passed, 1 acceptance failed, 2 bad input
    (a typed ``wbc.exceptions.WbcError``, printed on stderr)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        _check_args(args)
        code = int(args.func(args))
        if getattr(args, "live", False):
            _hold_live(args.hold)
        return code
    except WbcError as exc:
        print(f"wbc {args.command}: error: {exc}", file=sys.stderr)
        return 2
    finally:
        _close_live()


def _check_args(args) -> None:
    """Checks common to every command, before any run.

    Raises:
        InvalidInputError: an output file's directory does not exist; ``--hold`` is negative or given without
            ``--live``.
    """
    from wbc.exceptions import InvalidInputError

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
