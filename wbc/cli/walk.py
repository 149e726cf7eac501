"""``wbc walk``: plan a walk from the robot's reference stance and track it with the 500 Hz kinematic QP."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.cli.output import add_outputs, deadline_misses, open_live, print_summary, progress, write_outputs
from wbc.cli.robots import add_robot_options, robot_from_args
from wbc.cli.ros2 import add_run_options, attach, finish
from wbc.exceptions import InvalidInputError

__all__ = ["register", "cmd_walk", "leg_reach", "velocity_command", "MIN_STEPS"]

MIN_STEPS = 2  # one step forward and the closing step


def leg_reach(robot) -> float:
    """Largest fore-aft distance (m) between the two soles in double support that the legs can span.

    Geometric bound: leg length l (sum of the distances between the joint origins from the hip to the sole
    frame, ``q_ref``) and hip height h above the sole at ``q_ref``; with the hips above the mid-point the
    soles are at most ``2 sqrt(l^2 - h^2)`` apart. A step moves the feet mid-point by the step length, so
    the soles are one step length apart in double support.
    """
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


def check_walk_args(args, robot) -> None:
    """Refuse walk parameters that cannot be walked, before any run.

    Raises:
        InvalidInputError: ``--steps`` < 2, ``--step-length`` negative or beyond :func:`leg_reach`.
    """
    if args.steps < MIN_STEPS:
        raise InvalidInputError(f"--steps {args.steps}: a walk needs at least {MIN_STEPS} steps (valid: steps >= "
                                f"{MIN_STEPS}; the last step brings the feet side by side)")
    if args.step_length is not None:
        reach = leg_reach(robot)
        if not (0.0 <= args.step_length <= reach):
            raise InvalidInputError(f"--step-length {args.step_length} m is beyond the reach of {robot.name}'s legs "
                                    f"(valid: 0 <= step length <= {reach:.3f} m)")


def velocity_command(args, robot) -> dict:
    """``--vx/--vy/--wz`` (m/s, m/s, deg/s) → per-step ``--step-length``, lateral step and ``--turn`` (rad), with the
    step duration ``t_ss + t_ds`` of the robot's gait (the walk starts and stops at rest: the first step leaves
    from standing, the last one closes the feet). Returns extra :func:`wbc.gait.plan_walk` keywords."""
    vx, vy, wz = getattr(args, "vx", None), getattr(args, "vy", None), getattr(args, "wz", None)
    if vx is None and not vy and wz is None:
        return {}
    vx = 0.0 if vx is None else vx  # a velocity command: what is not commanded is 0
    gait = dict(robot.gait)
    period = float(gait.get("t_ss", 0.8)) + float(gait.get("t_ds", 0.3))
    args.step_length = vx * period
    if wz is not None:
        args.turn = math.radians(wz) * period
    if not vy:
        return {}
    return {"step_lateral": vy * period, "first_side": "left" if vy > 0 else "right"}


def cmd_walk(args) -> int:
    """`wbc walk`: plan, walk, print and write the outputs; exit code 0 passed, 1 failed criteria."""
    from wbc.scenarios.acceptance import walk_passes
    from wbc.scenarios.walk import plan_default_walk, run_walk, walk_summary
    from wbc.viz.overlays import walk_overlays

    robot = robot_from_args(args)
    velocity = velocity_command(args, robot)
    check_walk_args(args, robot)
    plan = plan_default_walk(robot, n_steps=args.steps, step_length=args.step_length,
                             step_width=args.step_width, turn=args.turn, dt=args.dt, **velocity)
    viewer = pacer = None
    if args.live:
        from wbc.viz.live_overlays import LiveOverlays

        viewer, pacer = open_live(robot)
        viewer.set_overlays(LiveOverlays(robot, plan))  # planned footsteps, ZMP and DCM too
    viewer = progress(args, float(plan.t[-1]), viewer, desc="wbc walk")
    target, ros2_pub = attach(args, robot, viewer, args.dt)  # publisher only with --ros2/--bag
    try:
        run = run_walk(robot, plan, solver=args.solver, viewer=target, pacer=pacer)
    finally:
        if viewer is not None:
            viewer.close()
        finish(ros2_pub)
    summary = walk_summary(robot, plan, run)
    summary["solver"] = args.solver
    summary["deadline_misses"] = deadline_misses(run.tick_time, args.dt)
    passed, failures = walk_passes(summary)
    summary["passed"] = passed
    summary["failed_criteria"] = failures
    print(f"wbc walk: {robot.name}, {summary['steps']} steps, {summary['ticks']} ticks at "
          f"{1 / args.dt:.0f} Hz, solver {args.solver}")
    print_summary(summary)
    scene = walk_overlays(robot, plan, run)
    write_outputs(args, summary, run, robot, overlays=scene["points"], scene=scene)
    return 0 if passed else 1


def register(sub, add_outputs=add_outputs) -> None:
    """Add the ``walk`` sub-command to ``wbc``'s sub-parsers (``add_outputs`` adds --json/--log/--out/--live)."""
    from wbc.backends import DEFAULT_SOLVER, available_solvers

    walk = sub.add_parser("walk", help="walk a humanoid under the 500 Hz kinematic QP controller",
                          description="Plan a straight (or turning) walk from the robot's reference stance and track "
                                      "it with the 500 Hz kinematic QP; prints a summary with acceptance criteria.")
    walk.add_argument("--robot", default="talos", help="catalog name, robot file (.toml) or URDF path (default talos)")
    walk.add_argument("--steps", type=int, default=8,
                      help=f"number of steps, >= {MIN_STEPS}, the last one bringing the feet side by side: the feet "
                           "advance (steps - 1) x step length (default 8)")
    walk.add_argument("--step-length", type=float, default=None,
                      help="m, feet advance per step, at most the leg's reach (default: the robot's, talos 0.15)")
    walk.add_argument("--step-width", type=float, default=None, help="m (default: current feet distance)")
    walk.add_argument("--turn", type=float, default=0.0, help="yaw change per step, rad (default 0)")
    walk.add_argument("--vx", type=float, default=None,
                      help="forward velocity command, m/s (sets --step-length = vx x step duration t_ss + t_ds)")
    walk.add_argument("--vy", type=float, default=0.0,
                      help="lateral velocity command, m/s, + left (side-steps of vy x step duration)")
    walk.add_argument("--wz", type=float, default=None,
                      help="turning velocity command, deg/s (sets --turn = wz x step duration)")
    walk.add_argument("--solver", default=DEFAULT_SOLVER, choices=available_solvers(), help=f"QP backend (default {DEFAULT_SOLVER})")
    walk.add_argument("--dt", type=float, default=0.002, help="control period, s (default 0.002)")
    add_outputs(walk)
    add_robot_options(walk)
    add_run_options(walk)
    walk.set_defaults(func=cmd_walk)
