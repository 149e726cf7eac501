"""wbc: whole-body kinematics and control for humanoid robots, built on Pinocchio.

Data flows one way: robot model (:func:`load_robot`) → kinematics (:class:`Configuration`) → tasks and
constraints (:mod:`wbc.tasks`, :mod:`wbc.constraints`) → one QP per tick (:class:`KinematicController`) →
command v, integrated on the manifold.
"""

from wbc.configuration import Configuration
from wbc.formulations.velocity import KinematicController
from wbc.robot import Robot, catalog, load_robot
from wbc.solve import solve_ik

__all__ = ["Configuration", "KinematicController", "Robot", "catalog", "load_robot", "solve_ik"]
__version__ = "0.1.0"
