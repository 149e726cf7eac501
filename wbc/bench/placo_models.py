"""Load wbc robots into placo: URDF text with extra fixed links, and the folder placo resolves meshes from.

placo builds its own Pinocchio model from URDF text, so frames that wbc adds in Python (e.g. G1's soles) and the
frame names placo's ``HumanoidRobot`` demands (``left_foot``, ``right_foot``, ``trunk``) become massless links
attached by fixed joints.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pinocchio as pin

from wbc.robot import Robot, example_robot_data_dir

__all__ = ["urdf_with_frames", "placo_model_directory", "placo_robot_wrapper", "placo_humanoid"]


def _fmt(x: np.ndarray) -> str:
    return " ".join(f"{float(v):.17g}" for v in x)


def urdf_with_frames(robot: Robot, extra: dict[str, tuple[str, pin.SE3]] | None = None) -> str:
    """URDF text of ``robot`` plus one massless fixed link per added frame.

    Args:
        robot: the wbc robot; its ``added_frames`` are included.
        extra: more frames, name -> (parent frame name, placement in the parent frame).

    Returns:
        The URDF text. A parent that is not a URDF link (a frame added by wbc) is resolved to the link it hangs
        from, composing the placements.
    """
    text = robot.urdf_path.read_text()
    frames = dict(robot.added_frames)
    frames.update(extra or {})
    model = robot.model
    snippets = []
    for name, (parent, placement) in frames.items():
        if f'<link name="{name}"' in text:
            continue
        link, pose = parent, placement
        while f'<link name="{link}"' not in text:
            fid = model.getFrameId(link)
            frame = model.frames[fid]
            parent_frame = model.frames[frame.parentFrame]
            pose = parent_frame.placement.actInv(frame.placement) * pose
            link = parent_frame.name
        rpy = pin.rpy.matrixToRpy(pose.rotation)
        snippets.append(
            f'  <link name="{name}"/>\n'
            f'  <joint name="{name}_bench_fixed" type="fixed">\n'
            f'    <parent link="{link}"/>\n    <child link="{name}"/>\n'
            f'    <origin xyz="{_fmt(pose.translation)}" rpy="{_fmt(rpy)}"/>\n'
            f'  </joint>\n'
        )
    idx = text.rfind("</robot>")
    return text[:idx] + "".join(snippets) + text[idx:]


def placo_model_directory(robot: Robot) -> str:
    """Folder placo resolves ``package://`` mesh URIs from (example-robot-data's share folder, else the URDF's)."""
    if "package://" in robot.urdf_path.read_text():
        return str(example_robot_data_dir())
    return str(robot.urdf_path.parent)


def _check_same_joints(robot: Robot, model) -> None:
    if list(model.names) != list(robot.model.names):
        raise RuntimeError(f"placo orders the joints of {robot.name} differently from wbc")


@lru_cache(maxsize=8)
def _cached_wrapper(directory: str, urdf: str):
    import placo

    return placo.RobotWrapper(directory, placo.Flags.ignore_collisions, urdf)


def placo_robot_wrapper(robot: Robot):
    """A ``placo.RobotWrapper`` of ``robot`` (same joint order as ``robot.model``), state set to ``q_ref``."""
    wrapper = _cached_wrapper(placo_model_directory(robot), urdf_with_frames(robot))
    _check_same_joints(robot, wrapper.model)
    wrapper.state.q = robot.q_ref.copy()
    wrapper.state.qd = np.zeros(robot.nv)
    wrapper.update_kinematics()
    return wrapper


def placo_humanoid(robot: Robot):
    """A ``placo.HumanoidRobot`` of ``robot`` with the frames it demands: ``left_foot``/``right_foot`` at the soles
    and ``trunk`` at the torso frame; state set to ``q_ref``."""
    import placo

    ident = pin.SE3.Identity()
    extra = {"left_foot": (robot.left_sole, ident), "right_foot": (robot.right_sole, ident),
             "trunk": (robot.torso, ident)}
    humanoid = placo.HumanoidRobot(placo_model_directory(robot), placo.Flags.ignore_collisions,
                                   urdf_with_frames(robot, extra))
    _check_same_joints(robot, humanoid.model)
    humanoid.state.q = robot.q_ref.copy()
    humanoid.state.qd = np.zeros(robot.nv)
    humanoid.update_kinematics()
    return humanoid


def reset_at_reference(model, robot: Robot) -> None:
    """Put a placo robot (``placo_robot_wrapper`` or ``placo_humanoid``) at ``robot.q_ref``, at rest (q̇ = q̈ = 0),
    and update its kinematics."""
    model.state.q = robot.q_ref.copy()
    model.state.qd = np.zeros(robot.nv)
    model.state.qdd = np.zeros(robot.nv)
    model.update_kinematics()


def kinematics_solver(model, dt: float, regularization: float):
    """A placo ``KinematicsSolver`` on ``model`` with period ``dt`` (s), the given regularisation and joint
    position and velocity limits enabled (as every placo set-up of the benchmarks uses it)."""
    import placo

    solver = placo.KinematicsSolver(model)
    solver.dt = dt
    solver.problem.regularization = regularization
    solver.enable_joint_limits(True)
    solver.enable_velocity_limits(True)
    return solver
