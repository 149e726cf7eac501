"""wbc: whole-body kinematics and control for humanoid robots, built on Pinocchio."""

from wbc.robot import Robot, catalog, load_robot

__all__ = ["Robot", "catalog", "load_robot"]
__version__ = "0.1.0"
