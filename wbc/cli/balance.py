"""``wbc balance BEHAVIOUR``: run a balance behaviour (shift, one-leg, wave, squat, reach) on a robot.

Same outputs as ``wbc walk``: the summary is printed; ``--json`` writes it, ``--log`` writes the npz time series
(format in :mod:`wbc.scenarios.balance`), ``--out`` a self-contained meshcat HTML recording (CoM, its ground
projection and target, executed ZMP and DCM, support polygons, footprints, sole paths:
:func:`wbc.viz.overlays.balance_overlays`), ``--live`` shows the motion in meshcat paced to real time.
Exit code 0 when the behaviour met its acceptance criteria, 1 when it did not, 2 on bad input.
"""

from __future__ import annotations

import argparse

from wbc.cli.kernels import compile_for_command
from wbc.cli.output import add_deadline_misses, open_live, print_summary, progress, write_outputs, write_recording
from wbc.cli.robots import add_robot_options, robot_from_args
from wbc.cli.ros2 import add_run_options, attach, finish
from wbc.cli.validate import check_jump, finite, solver_name
from wbc.exceptions import InvalidInputError

__all__ = ["register", "cmd_balance"]


def cmd_balance(args) -> int:
    """`wbc balance BEHAVIOUR`: run, print and write the outputs; exit code 0 passed, 1 failed criteria."""
    from wbc.scenarios.balance import balance_summary, run_balance

    if args.behaviour == "jump":  # kinematic preview of the planned jump (wbc.scenarios.balance_jump)
        return _jump_preview(args)
    robot = robot_from_args(args)
    options = {}
    if args.behaviour == "one-leg" and args.stance is not None:
        options["stance"] = args.stance
    if args.behaviour == "one-leg" and args.height is not None:
        options["height"] = args.height
    if args.behaviour == "reach" and args.hand is not None:
        options["hand"] = args.hand
    viewer = pacer = None
    if args.live:
        viewer, pacer = open_live(robot, args.live_start_now)
    compile_for_command("balance", quiet=getattr(args, "quiet", False))  # a first run: its kernels, in parallel, now
    viewer = progress(args, None, viewer, desc=f"wbc balance {args.behaviour}")
    target, ros2_pub = attach(args, robot, viewer, args.dt)  # publisher only with --ros2/--bag
    try:
        run = run_balance(robot, args.behaviour, dt=args.dt, solver=args.solver, viewer=target, pacer=pacer,
                          **options)
    finally:
        if viewer is not None:
            viewer.close()
        finish(ros2_pub)
    summary = balance_summary(robot, run)
    summary["solver"] = args.solver
    add_deadline_misses(summary, run.tick_time, args.dt)
    print(f"wbc balance {args.behaviour}: {robot.name}, {summary['ticks']} ticks at {1 / args.dt:.0f} Hz, "
          f"solver {args.solver}")
    print_summary(summary)
    from wbc.viz.overlays import balance_overlays

    scene = balance_overlays(robot, run)
    overlays = {**scene["points"], **run.extra["behaviour"].overlays(run)}
    out, args.out = args.out, None
    write_outputs(args, summary, run, robot)
    if out:
        write_recording(robot, run, out, overlays=overlays, polygons=run.polygons(robot),
                        outlines=scene["outlines"], paths=scene["paths"])
    return 0 if summary["passed"] else 1


def check_balance_args(args) -> None:
    """``wbc balance`` checks before any run (called by :func:`wbc.cli.main`).

    Raises:
        InvalidInputError: ``--dt`` out of range; ``--height`` given to a behaviour other than jump and one-leg,
            or not in (0, 0.5] m for one-leg; jump: ``--height``/``--count`` beyond what legs or memory allow.
    """
    from wbc.cli.walk import check_dt

    check_dt(args.dt)
    if args.height is not None and args.behaviour not in ("jump", "one-leg"):
        raise InvalidInputError(f"--height applies to jump and one-leg, not to {args.behaviour}")
    if args.behaviour == "one-leg" and args.height is not None and not 0.0 < args.height <= 0.5:
        raise InvalidInputError(f"one-leg --height is the swing sole's lift, valid 0 < height <= 0.5 m, "
                                f"got {args.height!r}")
    if args.behaviour == "jump":
        args.height = 0.08 if args.height is None else args.height
        from wbc.gait.jump_plan import JumpPlan

        defaults = JumpPlan(height=0.08)  # the preview's plan: default crouch and extension
        check_jump(args.height, defaults.stroke, args.count, args.dt)


def _jump_preview(args) -> int:
    """``wbc balance jump``: the kinematic preview of :mod:`wbc.scenarios.balance_jump`; exit code 0."""
    import numpy as np

    from wbc.scenarios.balance_jump import preview_jump, preview_summary

    robot = robot_from_args(args)
    viewer = pacer = None
    if args.live:
        viewer, pacer = open_live(robot, args.live_start_now)
    try:
        run = preview_jump(robot, height=args.height, forward=args.forward, count=args.count, dt=args.dt,
                           solver=args.solver, viewer=viewer, pacer=pacer)
    finally:
        if viewer is not None:
            viewer.close()
    summary = preview_summary(robot, run)
    print(f"wbc balance jump: {robot.name}, {len(run.t)} ticks at {1 / args.dt:.0f} Hz, solver {args.solver}")
    print_summary(summary)
    out, args.out = args.out, None
    write_outputs(args, summary, run, robot)
    if out:
        write_recording(robot, run, out, overlays={"com": run.com,
                                                   "com_ground": np.c_[run.com[:, :2], np.zeros(len(run.t))]})
    return 0


def register(subparsers, add_outputs) -> None:
    """Add the ``balance`` sub-command to ``wbc``'s sub-parsers (``add_outputs`` adds --json/--log/--out/--live)."""
    from wbc.solvers import DEFAULT_SOLVER
    from wbc.scenarios.balance import BEHAVIOURS

    p = subparsers.add_parser(
        "balance", help="balance behaviours (shift, one-leg, wave, squat, reach) under the 500 Hz kinematic QP",
        description="Run a balance behaviour on a robot under the 500 Hz kinematic QP.", formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="shift: CoM over the left foot, the right foot, then centred.  one-leg: CoM over one foot, lift the "
               "other 10 cm, hold 3 s, put it back.  wave: both arms wave 5 s.  squat: CoM down 15 cm and up, 3 "
               "times.  reach: a hand target 0.6 m in front of the chest, reached as far as balance allows.",
    )
    p.add_argument("behaviour", choices=[*BEHAVIOURS, "jump"], help="behaviour to run (jump: kinematic preview of "
                   "the planned jump of wbc sim jump, no physics)")
    p.add_argument("--robot", default="talos", help="catalog name, robot file (.toml) or URDF path (default talos)")
    p.add_argument("--stance", choices=["left", "right"], default=None,
                   help="one-leg: the foot that stays on the ground (default left)")
    p.add_argument("--hand", choices=["left", "right"], default=None, help="reach: the reaching hand (default right)")
    p.add_argument("--solver", default=DEFAULT_SOLVER, type=solver_name, metavar="SOLVER",
                   help=f"QP backend: fast, daqp, proxqp or an installed qpsolvers backend (default {DEFAULT_SOLVER})")
    p.add_argument("--dt", type=float, default=0.002, help="control period, s (default 0.002; valid 0.0001..0.02)")
    p.add_argument("--height", type=float, default=None,
                   help="jump: planned apex CoM rise, m (default 0.08; at most 0.9 m: push force <= 10 x weight); "
                        "one-leg: lift of the swing sole, m (default 0.10)")
    p.add_argument("--forward", type=finite(0.0), default=0.0, help="jump: planned forward foot displacement, m")
    p.add_argument("--count", type=int, default=1, help="jump: number of jumps (default 1)")
    add_outputs(p)
    add_robot_options(p)
    add_run_options(p)
    p.set_defaults(func=cmd_balance, check=check_balance_args)
