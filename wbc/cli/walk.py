"""``wbc walk``: plan a walk from the robot's reference stance and track it with the 500 Hz kinematic QP."""

from __future__ import annotations

import math

import numpy as np

from wbc.cli.kernels import compile_for_command
from wbc.cli.output import add_deadline_misses, add_outputs, open_live, print_summary, progress, status, write_outputs
from wbc.cli.robots import add_robot_options, robot_from_args
from wbc.cli.ros2 import add_run_options, attach, finish, real_time
from wbc.cli.validate import check_range, check_ticks, finite, real, solver_name
from wbc.analysis.legs import leg_reach, leg_rise
from wbc.exceptions import InvalidInputError

__all__ = ["register", "cmd_walk", "leg_reach", "leg_rise", "velocity_command", "check_command_values",
           "check_terrain_for_robot", "terrain_crossing", "crossing_criterion", "choose_steps", "check_steps",
           "MIN_STEPS", "DEFAULT_STEPS"]

MIN_STEPS = 2  # one step forward and the closing step

#: Control period range of the kinematic runs (s): below, the period is shorter than one QP tick (its time:
#: benchmarks/README.md); above, the gait's phases span too few ticks (the 0.3 s double support of talos: 15).
DT_RANGE = (1e-4, 0.02)


def check_terrain_for_robot(terrain, robot, option: str = "--terrain") -> None:
    """Refuse, before any work, stairs the robot cannot walk: a tread shorter than its sole (the whole sole
    stands on each tread) or a rise beyond :func:`leg_rise`.

    Args:
        terrain: a :class:`wbc.terrain.Terrain` (only stairs, with ``treads``, are checked). robot: the robot.
        option: the option as typed, for the message.

    Raises:
        InvalidInputError: naming the terrain, the tread or rise, and the robot's bound.
    """
    treads = getattr(terrain, "treads", ())
    if not treads:
        return
    sole = float(robot.sole_length)
    short = [b - a for a, b, _ in treads if math.isfinite(a) and math.isfinite(b) and b - a < sole]
    if short:
        raise InvalidInputError(f"{option} {terrain.name}: a {min(short):.3g} m tread is shorter than {robot.name}'s "
                                f"{sole:.3g} m sole (valid: TREAD >= {sole:.3g} m: the whole sole stands on each "
                                "tread)")
    end = terrain.end_x if terrain.end_x is not None else math.inf  # (not the drop beyond an up flight's landing)
    rise = max((abs(z1 - z0) for (_, _, z0), (a1, _, z1) in zip(treads[:-1], treads[1:]) if a1 <= end), default=0.0)
    bound = leg_rise(robot)
    if rise > bound:
        raise InvalidInputError(f"{option} {terrain.name}: a {rise:.3g} m rise is beyond the reach of {robot.name}'s "
                                f"legs (valid: RISE <= {bound:.3f} m: hip height above the sole minus the leg folded "
                                "to its shortest at the knee's limit)")


def terrain_crossing(terrain, left_x: float, right_x: float, sole_length: float) -> dict:
    """Summary entries of whether a walk ends past its terrain: ``terrain_end_x_m`` (:attr:`wbc.terrain.Terrain.end_x`)
    and ``terrain_shortfall_m``, the distance (m) the rear sole's heel still lacks to pass it (<= 0: crossed).
    Empty for a terrain without an end.

    Args:
        left_x, right_x: final x (m, world) of the two sole frames. sole_length: m.
    """
    end = getattr(terrain, "end_x", None)
    if end is None:
        return {}
    return {"terrain_end_x_m": float(end),
            "terrain_shortfall_m": float(end - (min(left_x, right_x) - 0.5 * sole_length))}


def crossing_criterion():
    """The :class:`~wbc.scenarios.framework.Criterion` "the walk crosses its terrain" (``terrain_shortfall_m`` <= 0)."""
    from wbc.scenarios.framework import Criterion

    return Criterion("the walk crosses its terrain (both heels past its end, terrain_shortfall_m)",
                     "terrain_shortfall_m", "<=", 0.0)


def check_dt(dt: float) -> None:
    """Refuse a control period outside :data:`DT_RANGE` (reason in the message).

    Raises:
        InvalidInputError: ``dt`` not finite or outside the range.
    """
    check_range("--dt", dt, *DT_RANGE, "the period must fit one QP tick (>= 0.1 ms) and sample the gait's "
                "phases (<= 20 ms)")


def _catalog_period(name: str) -> float | None:
    """Step duration t_ss + t_ds (s) from a catalog robot's descriptor (``wbc/robots/<name>.toml``), read without
    building the robot; None for a URDF path or a descriptor without it."""
    import importlib.resources
    import tomllib

    try:
        with (importlib.resources.files("wbc.robots") / f"{name}.toml").open("rb") as f:
            gait = tomllib.load(f).get("gait", {})
        return float(gait["t_ss"]) + float(gait["t_ds"])
    except (OSError, KeyError, ValueError, TypeError, tomllib.TOMLDecodeError):
        return None


def precheck_walk_args(args) -> None:
    """The checks of :func:`check_walk_args` that need no robot model (called by :func:`wbc.cli.main` before the
    robot is loaded): ``--steps`` >= 2, ``--dt``, and the run's memory for a catalog robot.

    Raises:
        InvalidInputError: see :func:`check_walk_args`.
    """
    check_steps(args.steps)
    check_dt(args.dt)
    check_terrain(args)
    period = _catalog_period(str(args.robot))
    if period is not None and args.steps is not None:  # (a count chosen to cross the terrain: checked then)
        check_ticks(f"--steps {args.steps} --dt {args.dt:g}", (args.steps + 2) * period, args.dt)


def check_steps(steps: int | None) -> None:
    """Refuse a walk of fewer than :data:`MIN_STEPS` steps (None: not given, chosen later, :func:`choose_steps`).

    Raises:
        InvalidInputError: naming ``--steps`` and the valid range.
    """
    if steps is not None and steps < MIN_STEPS:
        raise InvalidInputError(f"--steps {steps}: a walk needs at least {MIN_STEPS} steps (valid: steps >= "
                                f"{MIN_STEPS}; the last step brings the feet side by side)")


#: Steps of a walk when ``--steps`` is not given and the terrain has no end to cross (:func:`choose_steps`).
DEFAULT_STEPS = 8


def choose_steps(args, robot, terrain, *, blind: bool = False, prog: str = "wbc walk") -> None:
    """``--steps`` not given (``args.steps`` None): on a terrain with an end (:attr:`wbc.terrain.Terrain.end_x`:
    stairs, slope) the fewest steps that cross it, both heels past its end
    (:func:`wbc.scenarios.terrain_walk.default_steps` with ``args.step_length`` and ``args.step_width``), else
    :data:`DEFAULT_STEPS`; ``args.steps`` is set. A count the user gave is kept (the walk may then end short: the
    crossing criterion says so).

    Args:
        terrain: a :class:`wbc.terrain.Terrain` or None. blind: the walk is planned on flat ground. prog: the
            command, for the note printed on stdout (the count chosen).

    Raises:
        GaitError: a step without a foothold on the way (as the plan would).
    """
    if args.steps is not None:
        return
    chosen = None
    if terrain is not None and terrain.end_x is not None:
        from wbc.scenarios.terrain_walk import default_steps

        chosen = default_steps(robot, terrain, blind=blind, step_length=args.step_length,
                               step_width=getattr(args, "step_width", None))
        if chosen is not None:
            print(f"{prog}: note: --steps not given: {chosen} steps, the fewest that cross {terrain.name} (both heels "
                  f"past x = {terrain.end_x:.3f} m)", flush=True)
    args.steps = DEFAULT_STEPS if chosen is None else chosen


def check_terrain(args) -> None:
    """Parse ``--terrain`` once, before any work: ``args.terrain`` becomes a :class:`wbc.terrain.Terrain`.

    Raises:
        InvalidInputError: (``TerrainError``) the description cannot be parsed; the message names the field and
            the valid forms.
    """
    from wbc.terrain import Terrain, parse_terrain

    spec = getattr(args, "terrain", None)
    if spec is not None and not isinstance(spec, Terrain):
        args.terrain = parse_terrain(spec)


def check_walk_args(args, robot) -> None:
    """Refuse walk parameters that cannot be walked, before any run; a message names the option the user gave
    (``--vx`` when the step length comes from it).

    Raises:
        InvalidInputError: ``--steps`` < 2 or so many that the run would not fit in memory, ``--dt`` out of
            :data:`DT_RANGE`, ``--step-length`` (or ``--vx``) negative or beyond :func:`leg_reach`.
    """
    check_steps(args.steps)
    check_dt(args.dt)
    gait = dict(robot.gait)
    period = float(gait.get("t_ss", 0.8)) + float(gait.get("t_ds", 0.3))
    if args.steps is not None:  # (else chosen, and checked, once the terrain is known: cmd_walk)
        check_ticks(f"--steps {args.steps} --dt {args.dt:g}", (args.steps + 2) * period, args.dt)
    reach = leg_reach(robot)
    check_command_values(args, robot.name, reach, period)
    check_step_command(args, reach, period)
    if args.step_length is not None:
        if not (0.0 <= args.step_length <= reach):
            source = getattr(args, "step_length_source", None)
            if source is not None and args.step_length < 0:
                raise InvalidInputError(f"{source}: walking backwards is not planned (valid: 0 <= vx <= "
                                        f"{reach / period:.3f} m/s)")
            if source is not None:  # the step length came from --vx
                raise InvalidInputError(
                    f"{source} gives a step length of {args.step_length:.3g} m, beyond the reach of {robot.name}'s "
                    f"legs (valid: 0 <= vx <= {reach / period:.3f} m/s, i.e. step length <= {reach:.3f} m per "
                    f"{period:g} s step)")
            if args.step_length < 0:
                raise InvalidInputError(f"--step-length {args.step_length:g} m: walking backwards is not planned "
                                        f"(valid: 0 <= step length <= {reach:.3f} m, {robot.name}'s leg reach)")
            raise InvalidInputError(f"--step-length {args.step_length:g} m is beyond the reach of {robot.name}'s legs "
                                    f"(valid: 0 <= step length <= {reach:.3f} m)")


def check_command_values(args, name: str, reach: float, period: float) -> None:
    """Refuse a NaN or infinite ``--step-length``, ``--vx``, ``--vy`` or ``--wz`` (parsed by
    :func:`wbc.cli.validate.real`) with the range valid for this robot.

    Args:
        name: the robot's name. reach: its legs' reach (m, :func:`leg_reach`). period: step duration (s).

    Raises:
        InvalidInputError: naming the option, its value and the robot's valid range.
    """
    ranges = {
        "vx": f"0 <= vx <= {reach / period:.3f} m/s: {name}'s leg reach {reach:.3f} m per {period:g} s step",
        "vy": f"|vy| <= {reach / period:.3f} m/s: {name}'s leg reach {reach:.3f} m per {period:g} s step",
        "wz": f"|wz| < {MAX_TURN_DEG / period:.4g} deg/s: {MAX_TURN_DEG:g} deg per {period:g} s step",
        "step_length": f"0 <= step length <= {reach:.3f} m, {name}'s leg reach",
    }
    for dest, valid in ranges.items():
        value = getattr(args, dest, None)
        if dest == "step_length" and getattr(args, "step_length_source", None) is not None:
            continue  # computed from --vx, checked as --vx
        if value is not None and not math.isfinite(value):
            option = "--" + dest.replace("_", "-")
            raise InvalidInputError(f"{option} {value:g} is not a finite number (valid: {valid})")


#: Largest yaw change per step (deg): the planner's bound, |turn| < 90° per step (:func:`wbc.gait.plan_walk`).
MAX_TURN_DEG = 90.0


def check_step_command(args, reach: float, period: float) -> None:
    """Refuse a per-step command beyond the legs: the turn from ``--wz`` (or ``--turn``) beyond
    :data:`MAX_TURN_DEG`, a lateral step from ``--vy`` beyond ``reach``; messages name the option given.

    Args:
        reach: the legs' reach (m, :func:`leg_reach`). period: step duration (s).

    Raises:
        InvalidInputError: naming ``--wz``/``--turn`` or ``--vy``.
    """
    wz, vy = getattr(args, "wz", None), getattr(args, "vy", None) or 0.0
    if not abs(args.turn) < MAX_TURN_DEG:
        source = f"--wz {wz:g} deg/s gives {args.turn:.4g} deg per {period:g} s step" if wz is not None else \
            f"--turn {args.turn:g} deg per step"
        limit = f"|wz| < {MAX_TURN_DEG / period:.4g} deg/s" if wz is not None else f"|turn| < {MAX_TURN_DEG:g} deg"
        raise InvalidInputError(f"{source}: beyond what one step can turn (valid: {limit})")
    if abs(vy) * period > reach:
        raise InvalidInputError(f"--vy {vy:g} m/s gives a {abs(vy) * period:.3g} m side step per {period:g} s step, "
                                f"beyond the legs' reach (valid: |vy| <= {reach / period:.3f} m/s)")


def velocity_command(args, robot) -> dict:
    """``--vx/--vy/--wz`` (m/s, m/s, deg/s) → per-step ``--step-length``, lateral step and ``--turn`` (deg), with the
    step duration ``t_ss + t_ds`` of the robot's gait (the walk starts and stops at rest: the first step leaves
    from standing, the last one closes the feet). Returns extra :func:`wbc.gait.plan_walk` keywords."""
    vx, vy, wz = getattr(args, "vx", None), getattr(args, "vy", None), getattr(args, "wz", None)
    if vx is None and not vy and wz is None:
        return {}
    vx = 0.0 if vx is None else vx  # a velocity command: what is not commanded is 0
    gait = dict(robot.gait)
    period = float(gait.get("t_ss", 0.8)) + float(gait.get("t_ds", 0.3))
    args.step_length = vx * period
    args.step_length_source = f"--vx {vx:g}"
    if wz is not None:
        args.turn = wz * period
    if not vy:
        return {}
    return {"step_lateral": vy * period, "first_side": "left" if vy > 0 else "right"}


def cmd_walk(args) -> int:
    """`wbc walk`: plan, walk, print and write the outputs; exit code 0 passed, 1 failed criteria."""
    from wbc.scenarios.acceptance import walk_passes
    from wbc.scenarios.walk import plan_default_walk, run_walk, walk_summary
    from wbc.viz.overlays import walk_overlays

    status(args, f"wbc walk: loading {args.robot} ...")
    robot = robot_from_args(args)
    velocity = velocity_command(args, robot)
    check_walk_args(args, robot)
    check_terrain(args)
    terrain = getattr(args, "terrain", None)
    if terrain is not None:
        check_terrain_for_robot(terrain, robot)
    if args.steps is None:
        choose_steps(args, robot, terrain)
        check_walk_args(args, robot)  # (the count's run length)
    status(args, f"wbc walk: planning {args.steps} steps ...")
    terrain_walk = None
    if terrain is None or terrain.is_flat:
        plan = plan_default_walk(robot, n_steps=args.steps, step_length=args.step_length,
                                 step_width=args.step_width, turn=math.radians(args.turn), dt=args.dt, **velocity)
    else:
        from wbc.scenarios.terrain_walk import plan_default_terrain_walk

        terrain_walk = plan_default_terrain_walk(robot, terrain, n_steps=args.steps, step_length=args.step_length,
                                                 step_width=args.step_width, turn=math.radians(args.turn),
                                                 dt=args.dt, **velocity)
        plan = terrain_walk.plan
        planned = terrain_crossing(terrain, terrain_walk.footholds[-1][0, 3], terrain_walk.footholds[-2][0, 3],
                                   robot.sole_length) if len(terrain_walk.footholds) >= 2 else {}
        if planned.get("terrain_shortfall_m", 0.0) > 0:
            print(f"wbc walk: note: the {args.steps} planned steps end {planned['terrain_shortfall_m']:.3f} m before "
                  f"the end of {terrain.name} (x = {planned['terrain_end_x_m']:.3f} m): the walk will not cross it "
                  "(more --steps would)", flush=True)
    viewer = pacer = None
    if args.live:
        from wbc.viz.live_overlays import LiveOverlays

        viewer, pacer = open_live(robot, args.live_start_now, terrain=terrain)
        viewer.set_overlays(LiveOverlays(robot, plan))  # planned footsteps, ZMP and DCM too
    compile_for_command("walk", quiet=getattr(args, "quiet", False))  # a first run: its kernels, in parallel, now
    viewer = progress(args, float(plan.t[-1]), viewer, desc="wbc walk")
    clock_guard = real_time(args)  # before attach (which may clear args.ros2)
    target, ros2_pub = attach(args, robot, viewer, args.dt)  # publisher only with --ros2/--bag
    try:
        run = run_walk(robot, plan, solver=args.solver, viewer=target, pacer=pacer, clock_guard=clock_guard)
    finally:
        if viewer is not None:
            viewer.close()
        finish(ros2_pub)
    summary = walk_summary(robot, plan, run)
    summary["solver"] = args.solver
    add_deadline_misses(summary, run.tick_time, args.dt)
    passed, failures = walk_passes(summary)
    if terrain_walk is not None:
        from wbc.scenarios.terrain_walk import terrain_passes, terrain_summary

        summary.update(terrain_summary(terrain_walk, run.left_sole, run.right_sole, robot.sole_length,
                                       robot.sole_width))
        ok, more = terrain_passes(summary)
        passed, failures = passed and ok, failures + more
        summary.update(terrain_crossing(terrain, float(run.left_sole[-1][0, 3]), float(run.right_sole[-1][0, 3]),
                                        robot.sole_length))
        if "terrain_shortfall_m" in summary:
            from wbc.scenarios.framework import evaluate

            ok, more = evaluate(summary, [crossing_criterion()])
            passed, failures = passed and ok, failures + more
    summary["passed"] = passed
    summary["failed_criteria"] = failures
    print(f"wbc walk: {robot.name}, {summary['steps']} steps, {summary['ticks']} ticks at "
          f"{1 / args.dt:.0f} Hz, solver {args.solver}")
    print_summary(summary)
    scene = walk_overlays(robot, plan, run)
    if terrain_walk is not None:  # the terrain, and the planned footholds at their height
        from wbc.geometry import sole_polygon

        scene["terrain"] = terrain_walk.terrain
        scene["outlines"]["footsteps_planned"] = [
            np.c_[sole_polygon(H[0, 3], H[1, 3], math.atan2(H[1, 0], H[0, 0]), robot.sole_length, robot.sole_width),
                  np.full(4, H[2, 3] + 0.002)] for H in terrain_walk.footholds]
    write_outputs(args, summary, run, robot, overlays=scene["points"], scene=scene)
    return 0 if passed else 1


def register(sub, add_outputs=add_outputs) -> None:
    """Add the ``walk`` sub-command to ``wbc``'s sub-parsers (``add_outputs`` adds --json/--log/--out/--live)."""
    from wbc.solvers import DEFAULT_SOLVER

    walk = sub.add_parser("walk", help="walk a humanoid under the 500 Hz kinematic QP controller",
                          description="Plan a straight (or turning) walk from the robot's reference stance and track "
                                      "it with the 500 Hz kinematic QP; prints a summary with acceptance criteria.")
    walk.add_argument("--robot", default="talos", help="catalog name, robot file (.toml) or URDF path (default talos)")
    walk.add_argument("--steps", type=int, default=None,
                      help=f"number of steps, >= {MIN_STEPS}, the last one bringing the feet side by side: the feet "
                           f"advance (steps - 1) x step length (default {DEFAULT_STEPS}; on a --terrain with an end, "
                           "stairs or slope, the fewest steps whose footholds put both heels past it)")
    walk.add_argument("--step-length", type=real, default=None,
                      help="m, feet advance per step, at most the leg's reach (default: the robot's, talos 0.15)")
    walk.add_argument("--step-width", type=finite(0.0, lo_open=True), default=None,
                      help="m (default: current feet distance; on stairs the robot file's [stairs] step_width when it "
                           "gives one)")
    walk.add_argument("--turn", type=finite(-90.0, 90.0), default=0.0,
                      help="yaw change per step, deg (default 0; every angle option of wbc is in degrees)")
    walk.add_argument("--vx", type=real, default=None,
                      help="forward velocity command, m/s (sets --step-length = vx x step duration t_ss + t_ds)")
    walk.add_argument("--vy", type=real, default=0.0,
                      help="lateral velocity command, m/s, + left (side-steps of vy x step duration)")
    walk.add_argument("--wz", type=real, default=None,
                      help="turning velocity command, deg/s (sets --turn = wz x step duration)")
    walk.add_argument("--terrain", default="flat",
                      help="ground: flat | stairs:RISE:TREAD:N[:up|down|updown] | slope:DEG[:LENGTH] | "
                           "rough:AMPLITUDE:SEED | FILE.json/.toml (boxes, heightfield); m and degrees, see "
                           "wbc.terrain (default flat; on stairs the step length defaults to the tread)")
    walk.add_argument("--solver", default=DEFAULT_SOLVER, type=solver_name, metavar="SOLVER",
                      help="QP backend: fast, daqp, proxqp or an installed qpsolvers backend "
                           f"(default {DEFAULT_SOLVER})")
    walk.add_argument("--dt", type=float, default=0.002,
                      help=f"control period, s (default 0.002; valid {DT_RANGE[0]:g}..{DT_RANGE[1]:g})")
    add_outputs(walk)
    add_robot_options(walk)
    add_run_options(walk)
    walk.set_defaults(func=cmd_walk, check=precheck_walk_args)
