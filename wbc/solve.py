"""Stateless one-call entry point for scripting: :func:`solve_ik` (as Pink's ``solve_ik`` and mink's
``solve_ik``), beside the stateful :class:`~wbc.controllers.kinematic.KinematicController`.

One call builds the kinematics at ``q``, the velocity-level QP of :mod:`wbc.formulations.velocity` from the given tasks and
constraints, solves it once and returns the generalized velocity. Nothing is kept between calls (no warm start,
no previous command, no cached constraint rank): a 500 Hz loop should keep a :class:`KinematicController`
instead, which reuses its QP workspace and layout.
"""

from __future__ import annotations

import math

import numpy as np

from wbc.configuration import Configuration
from wbc.constraints.base import Constraint
from wbc.controllers.kinematic import KinematicController
from wbc.exceptions import InfeasibleProblemError, SolverError
from wbc.solvers import DEFAULT_SOLVER, QPBackend
from wbc.robot import Robot
from wbc.tasks.base import Task

__all__ = ["solve_ik"]


def solve_ik(robot: Robot, q: np.ndarray, tasks: list[Task], dt: float, constraints: list[Constraint] = (), *,
             solver: str | QPBackend = DEFAULT_SOLVER, damping: float = 1e-6, safe_fallback: bool = False
             ) -> np.ndarray:
    """Generalized velocity v that best achieves ``tasks`` at ``q`` under ``constraints`` over one period ``dt``.

    The problem is the one of :mod:`wbc.formulations.velocity`: min_v Σ_i ‖√w_i (J_i v − v*_i)‖² + ε‖v‖² subject to the
    equality, inequality and bound constraints, with v*_i = ė*_i − K_i e_i from each task's target. Integrate the
    result on the manifold with ``pinocchio.integrate(robot.model, q, v * dt)``.

    Args:
        robot: the robot (:func:`wbc.load_robot`).
        q: (nq,) configuration, Pinocchio order (free flyer: position m, quaternion xyzw, then joints rad/m),
            world frame; the base quaternion must have unit norm.
        tasks: weighted tasks (:mod:`wbc.tasks`), their targets already set.
        dt: period over which v is applied (s, > 0): sets the limits' velocity bounds and the contacts' rows.
        constraints: constraints (:mod:`wbc.constraints`): contacts, joint limits, CoM polygon, ...
        solver: QP backend name (:func:`wbc.solvers.available_solvers`) or a :class:`~wbc.solvers.base.QPBackend`.
        damping: ε, weight of ‖v‖² (> 0).
        safe_fallback: when the QP cannot be solved, return the controller's safe command (the soft tasks under
            the constraint objects only, or v = 0) instead of raising.

    Returns:
        (nv,) generalized velocity: base linear (m/s) and angular (rad/s) velocity in the base frame (Pinocchio's
        free-flyer convention), then joint velocities (rad/s, m/s).

    Raises:
        ConfigurationError: q has the wrong size, is not finite, or its quaternion is not unit.
        InvalidInputError: dt not finite and > 0, damping ≤ 0, or an object that is not a Task/Constraint.
        UnknownSolverError: unknown backend name.
        InfeasibleProblemError: the hard constraints conflict; ``conflicts`` holds the (constraint name, violation)
            pairs the diagnosis (:mod:`wbc.solvers.diagnosis`) named, largest first, also given in the message.
        SolverError: any other tick that is not ok (e.g. contacts that drift beyond the controller's tolerance),
            with the reason. Neither is raised with ``safe_fallback=True``.
    """
    config = Configuration(robot, q)
    # a function call, not a control tick: no tick budget (every failure-handling stage runs, the conflict is named)
    controller = KinematicController(robot, list(tasks), list(constraints), solver=solver, damping=damping,
                                     budget=math.inf)
    result = controller.solve(config, dt)
    if not result.ok and not safe_fallback:
        conflicts = ", ".join(f"{name} ({violation:.3g})" for name, violation in result.conflicts) or "none named"
        message = f"solve_ik: no solution ({result.message}); conflicting constraints: {conflicts}"
        if result.conflicts:
            raise InfeasibleProblemError(message, conflicts=list(result.conflicts))
        raise SolverError(message)
    return result.v
