"""``wbc robots`` (the catalog table), ``wbc robot init|check`` (robot files) and the robot options shared by every
command (``--robot NAME|FILE.toml|FILE.urdf`` and the frame overrides).

Bring your own humanoid: ``wbc robot init my.urdf -o my_robot.toml``, ``wbc robot check my_robot.toml``, then
``wbc walk --robot my_robot.toml`` (format: ``docs/pages/how-to/robot-file.md``). The frame options (``--left-sole`` ...)
override the robot file's (or catalog robot's) values and are checked like them.
"""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["register", "add_robot_options", "add_plant_options", "robot_from_args", "cmd_robots", "cmd_robot_init",
           "cmd_robot_check", "check_gait"]


def add_robot_options(p: argparse.ArgumentParser) -> None:
    """Frame options of ``--robot``: required for a bare URDF path, overrides of a robot file's or catalog robot's
    values otherwise (each checked: an unknown frame, a missing SRDF or a NaN size is an error, exit 2)."""
    g = p.add_argument_group("robot overrides (required with --robot my.urdf; override a robot file's values)")
    g.add_argument("--srdf", default=None, help="SRDF with the reference posture (group_state)")
    g.add_argument("--reference", default=None, help="name of the SRDF reference posture (e.g. half_sitting)")
    g.add_argument("--left-sole", default=None, help="left sole frame (z up, on the ground plane)")
    g.add_argument("--right-sole", default=None, help="right sole frame (z up, on the ground plane)")
    g.add_argument("--torso", default=None, help="torso frame (kept upright)")
    g.add_argument("--sole-length", type=float, default=None, help="m (default: from the foot's collision geometry)")
    g.add_argument("--sole-width", type=float, default=None, help="m (default: from the foot's collision geometry)")
    g.add_argument("--package-dir", action="append", default=[], help="folder searched for package:// meshes")


def add_plant_options(p: argparse.ArgumentParser, scope: str = "") -> None:
    """``--plant`` (the simulated robot's drives) and ``--state`` (what the controller reads), as ``wbc sim`` and
    ``wbc ros2 node --sim`` take them; ``scope`` opens their help (e.g. ``"--sim: "``)."""
    p.add_argument("--plant", choices=("realistic", "ideal"), default="realistic",
                   help=scope + "plant drives (wbc.sim.actuators): realistic (default: URDF joint damping and dry "
                                "friction, rotor armature, torque-speed envelope) or ideal (torque sources; "
                                "plant = model)")
    p.add_argument("--state", choices=("estimated", "ground-truth"), default="estimated",
                   help=scope + "what the controller reads: estimated (default: encoders, pelvis IMU and ankle F/T "
                                "sensors with noise and bias, wbc.sim.sensors, fused by "
                                "wbc.estimation.FloatingBaseEstimator; noise seeded by --seed) or ground-truth "
                                "(MuJoCo's qpos/qvel)")


def robot_from_args(args: argparse.Namespace):
    """Load ``args.robot`` (catalog name, or URDF path with the frame options of :func:`add_robot_options`).

    Raises:
        UnknownRobotError, RobotFileNotFoundError, RobotDescriptionError: see :func:`wbc.robot.load_robot`.
    """
    from wbc.robot import load_robot

    if not hasattr(args, "left_sole"):
        return load_robot(args.robot)
    return load_robot(args.robot, srdf=args.srdf, reference=args.reference, left_sole=args.left_sole,
                      right_sole=args.right_sole, torso=args.torso, package_dirs=args.package_dir,
                      sole_length=args.sole_length, sole_width=args.sole_width)


def cmd_robots(args: argparse.Namespace) -> int:
    """Print the catalog: name, DoF, mass, leg length, sole rectangle, default step."""
    from wbc.robot import catalog, load_robot

    print("| robot | nq | nv | mass kg | base height m | sole L×W m | step length m | single support s |")
    print("|---|---|---|---|---|---|---|---|")
    for name in catalog():
        r = load_robot(name)
        mass = sum(r.model.inertias[j].mass for j in range(1, r.model.njoints))
        gait = r.gait
        print(f"| {name} | {r.nq} | {r.nv} | {mass:.1f} | {r.q_ref[2]:.3f} | {r.sole_length:.3f}×{r.sole_width:.3f} | "
              f"{gait.get('step_length', '—')} | {gait.get('t_ss', '—')} |")
    return 0


def _relative(path: str, out_dir: Path) -> str:
    """How a robot file in ``out_dir`` names ``path``: ``erd:...`` inside example-robot-data, else relative."""
    import os

    from wbc.robot import example_robot_data_dir

    erd = example_robot_data_dir() / "example-robot-data" / "robots"
    p = Path(path).resolve()
    if p.is_relative_to(erd.resolve()):
        return "erd:" + p.relative_to(erd.resolve()).as_posix()
    return os.path.relpath(p, out_dir.resolve())


def _feasible_gait(spec):
    """The spec with its ``[gait]`` bounded by the legs (:func:`wbc.gait.feasibility.feasible_gait`) and the notes
    saying what was chosen and why."""
    from dataclasses import replace

    from wbc.gait.feasibility import feasible_gait
    from wbc.robot import build_robot

    from wbc.exceptions import GaitError

    try:
        gait, _, notes = feasible_gait(build_robot(spec), spec.gait)
    except GaitError as exc:
        return spec, [f"gait: not bounded by the legs (a nominal walk cannot be planned: {exc}); "
                      f"`wbc robot check` says what to change"]
    notes = [f"gait: {n}" for n in notes]
    if gait != spec.gait:
        notes.append(f"gait: chosen {gait} (was {spec.gait})")
    return replace(spec, gait=gait), notes


def cmd_robot_init(args: argparse.Namespace) -> int:
    """``wbc robot init my.urdf``: infer a robot file, check that it loads, write it and print what was guessed."""
    from dataclasses import replace

    from wbc.exceptions import InvalidInputError
    from wbc.robot_file import spec_to_toml
    from wbc.robot_inspect import infer_robot_spec

    out = Path(args.output) if args.output else Path(Path(args.urdf).stem + ".toml")
    if not out.parent.is_dir():
        raise InvalidInputError(f"-o {out}: directory {str(out.parent)!r} does not exist (create it first)")
    if out.exists() and not args.force:
        raise InvalidInputError(f"-o {out}: file exists (pass --force to overwrite)")
    spec, notes = infer_robot_spec(args.urdf, args.package_dir)
    spec, gait_notes = _feasible_gait(spec)
    notes += gait_notes
    out_dir = out.parent
    spec = replace(spec, urdf=_relative(spec.urdf, out_dir),
                   srdf=None if spec.srdf is None else _relative(spec.srdf, out_dir),
                   package_dirs=tuple(_relative(d, out_dir) for d in spec.package_dirs))
    header = (f"Robot file written by `wbc robot init {args.urdf}` (format: docs/pages/how-to/robot-file.md).\n"
              "What was guessed (check it with `wbc robot check`):\n" + "\n".join(f"- {n}" for n in notes))
    out.write_text(spec_to_toml(spec, comments={"header": header}))
    print(f"wbc robot init: wrote {out}")
    for n in notes:
        print(f"  guessed: {n}")
    return 0


def check_gait(robot) -> None:
    """The robot's gait (its ``[gait]`` table, or the one scaled from Talos's) and ``[stairs]`` step width against
    its legs: the stairs' step width wider than the sole (the feet side by side without overlapping), and a nominal
    walk (:func:`wbc.gait.feasibility.nominal_step_demand`, inverse kinematics of each leg, joint ranges clipped)
    reaching every sole target within :data:`~wbc.gait.feasibility.REACH_TOLERANCE` (a step longer or higher than
    the legs reach misses) with joint speeds within the URDF limits.

    Raises:
        RobotDescriptionError: names the gait, how far the legs miss it or how fast it drives a joint, and that
            joint.
    """
    from wbc.exceptions import RobotDescriptionError
    from wbc.gait.feasibility import REACH_TOLERANCE, nominal_step_demand

    gait, name = robot.gait, robot.name
    width = robot.stairs.get("step_width")
    if width is not None and width <= robot.sole_width:
        raise RobotDescriptionError(f"{name}: [stairs] step_width = {width} m puts the feet over each other (sole "
                                    f"width {robot.sole_width:.3f} m); valid: step_width > {robot.sole_width:.3f} m")
    demand = nominal_step_demand(robot, gait)
    if demand.reach_error > REACH_TOLERANCE:
        raise RobotDescriptionError(
            f"{name}: the legs cannot follow the gait {gait}: a nominal walk misses a sole target by "
            f"{demand.reach_error:.3f} m (at most {REACH_TOLERANCE} m) with joint {demand.reach_joint!r} at its "
            f"limit; shorten [gait] step_length or step_height")
    if demand.speed_ratio > 1.0:
        raise RobotDescriptionError(
            f"{name}: the gait {gait} asks joint {demand.speed_joint!r} for {demand.speed_ratio:.2f} x its URDF "
            f"speed limit in a nominal walk (valid: <= 1); lengthen [gait] t_ss / t_ds or shorten the step")


def cmd_robot_check(args: argparse.Namespace) -> int:
    """``wbc robot check my_robot.toml``: load it with every validation, check its gait against its legs
    (:func:`check_gait`) and print the report."""
    from wbc.robot import load_robot
    from wbc.robot_inspect import check_robot

    robot = load_robot(args.robot_file)
    report = check_robot(robot)
    check_gait(robot)
    print(f"wbc robot check: {args.robot_file}: ok")
    for k, v in report.items():
        print(f"  {k}: {v}")
    return 0


def register(subparsers, add_outputs=None) -> None:
    """Add the ``robots`` and ``robot`` sub-commands."""
    p = subparsers.add_parser("robots", help="list the robot catalog (names accepted by --robot)")
    p.set_defaults(func=cmd_robots)
    r = subparsers.add_parser("robot", help="robot files: `robot init my.urdf` writes one, `robot check` validates",
                              description="Robot files (--robot my_robot.toml, format in docs/pages/how-to/robot-file.md).")
    sub = r.add_subparsers(dest="robot_command", required=True)
    i = sub.add_parser("init", help="infer a robot file from a humanoid URDF and say what was guessed")
    i.add_argument("urdf", help="the humanoid's URDF")
    i.add_argument("-o", "--output", default=None, help="robot file to write (default: URDF stem + .toml)")
    i.add_argument("--force", action="store_true", help="overwrite the output file")
    i.add_argument("--package-dir", action="append", default=[], help="folder searched for package:// meshes")
    i.set_defaults(func=cmd_robot_init)
    c = sub.add_parser("check", help="load a robot file with every validation and print a report")
    c.add_argument("robot_file", help="robot file (.toml), catalog name or URDF")
    c.set_defaults(func=cmd_robot_check)
