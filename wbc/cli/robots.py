"""``wbc robots`` (the catalog table) and the ``--robot my.urdf`` frame options of ``wbc walk``.

Bring your own humanoid: ``wbc walk --robot my.urdf --srdf my.srdf --reference half_sitting --left-sole l_sole
--right-sole r_sole --torso torso`` (see README, "Bring your own humanoid").
"""

from __future__ import annotations

import argparse

__all__ = ["register", "add_robot_options", "robot_from_args", "cmd_robots"]


def add_robot_options(p: argparse.ArgumentParser) -> None:
    """Options naming the frames of a robot given as a URDF path (ignored for a catalog name)."""
    g = p.add_argument_group("robot from a URDF path (--robot my.urdf)")
    g.add_argument("--srdf", default=None, help="SRDF with the reference posture (group_state)")
    g.add_argument("--reference", default=None, help="name of the SRDF reference posture (e.g. half_sitting)")
    g.add_argument("--left-sole", default=None, help="left sole frame (z up, on the ground plane)")
    g.add_argument("--right-sole", default=None, help="right sole frame (z up, on the ground plane)")
    g.add_argument("--torso", default=None, help="torso frame (kept upright)")
    g.add_argument("--sole-length", type=float, default=None, help="m (default: from the foot's collision geometry)")
    g.add_argument("--sole-width", type=float, default=None, help="m (default: from the foot's collision geometry)")
    g.add_argument("--package-dir", action="append", default=[], help="folder searched for package:// meshes")


def robot_from_args(args: argparse.Namespace):
    """Load ``args.robot`` (catalog name, or URDF path with the frame options of :func:`add_robot_options`).

    Raises:
        UnknownRobotError, RobotFileNotFoundError, RobotDescriptionError: see :func:`wbc.robot.load_robot`.
    """
    from wbc.robot import load_robot

    if not str(args.robot).lower().endswith(".urdf"):
        return load_robot(args.robot)
    extra = {k: getattr(args, k) for k in ("sole_length", "sole_width") if getattr(args, k, None) is not None}
    return load_robot(args.robot, srdf=args.srdf, reference=args.reference, left_sole=args.left_sole,
                      right_sole=args.right_sole, torso=args.torso, package_dirs=args.package_dir, **extra)


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


def register(subparsers, add_outputs=None) -> None:
    """Add the ``robots`` sub-command."""
    p = subparsers.add_parser("robots", help="list the robot catalog (names accepted by --robot)")
    p.set_defaults(func=cmd_robots)
