"""Command line: ``wbc walk``, ``wbc balance``, ``wbc sim``, ``wbc bench`` (also ``python -m wbc``).

Each sub-command prints a summary, and can write it as JSON (``--json``), a log (``--log``, npz), a
self-contained meshcat HTML recording (``--out``), or show the motion live in meshcat (``--live``).
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
    p.add_argument("--live", action="store_true", help="show the motion live in meshcat (paced to real time)")


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


def _write_outputs(args, summary: dict, run, robot, overlays: dict | None = None) -> None:
    if args.json:
        args.json.write_text(json.dumps(summary, indent=2) + "\n")
        print(f"summary written to {args.json}")
    if args.log:
        run.save(args.log)
        print(f"log written to {args.log}")
    if args.out:
        from wbc.viz import record_html

        path = record_html(robot, run.t, run.q, args.out, overlays=overlays)
        print(f"meshcat recording written to {path} ({path.stat().st_size / 1e6:.1f} MB)")


def _live(robot):
    """(viewer, pacer) for --live: a meshcat server on 127.0.0.1 and a real-time pacer."""
    from wbc.viz import LiveViewer, RealTimePacer

    viewer = LiveViewer(robot)
    print(f"meshcat viewer: {viewer.url} (open it in a browser)")
    return viewer, RealTimePacer()


def cmd_walk(args) -> int:
    """`wbc walk`: plan, walk, print and write the outputs; exit code 0 passed, 1 failed criteria."""
    import numpy as np

    from wbc.robot import load_robot
    from wbc.scenarios.walk import plan_default_walk, run_walk, walk_summary
    from wbc.scenarios.acceptance import walk_passes

    from wbc.robot_cli import robot_from_args

    robot = robot_from_args(args) if hasattr(args, "left_sole") else load_robot(args.robot)
    plan = plan_default_walk(robot, n_steps=args.steps, step_length=args.step_length,
                             step_width=args.step_width, turn=args.turn, dt=args.dt)
    viewer = pacer = None
    if args.live:
        viewer, pacer = _live(robot)
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
    passed, failures = walk_passes(summary)
    summary["passed"] = passed
    summary["failed_criteria"] = failures
    print(f"wbc walk: {robot.name}, {summary['steps']} steps, {summary['ticks']} ticks at "
          f"{1 / args.dt:.0f} Hz, solver {args.solver}")
    _print_summary(summary)
    com = run.com
    zmp = np.c_[run.zmp_ref, np.zeros(len(run.t))]
    _write_outputs(args, summary, run, robot, overlays={"com": com, "zmp": zmp})
    return 0 if passed else 1


def build_parser() -> argparse.ArgumentParser:
    """The `wbc` argument parser with every sub-command (walk here; balance, sim, bench from their modules)."""
    from wbc.qp import DEFAULT_SOLVER, available_solvers

    parser = argparse.ArgumentParser(prog="wbc", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    walk = sub.add_parser("walk", help="walk a humanoid under the 500 Hz kinematic QP controller")
    walk.add_argument("--robot", default="talos", help="catalog name or URDF path (default talos)")
    walk.add_argument("--steps", type=int, default=8, help="number of steps (default 8)")
    walk.add_argument("--step-length", type=float, default=None, help="m (default: the robot's, talos 0.15)")
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

    for register in _extra_commands():
        register(sub, _add_outputs)
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
        return int(args.func(args))
    except WbcError as exc:
        print(f"wbc {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
