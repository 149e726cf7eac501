"""The general route of a kinematic tick (:mod:`wbc.controllers.general_route`): on a backend other than the
compiled tick's (here DAQP, path 'general:daqp') the command is the optimum of the assembled QP — checked against
quadprog (dense Goldfarb–Idnani) and the KKT conditions (scipy's bounded least squares) on that QP — including when
the hard equalities hold dependent rows (a contact given twice), which the route drops before its solve."""

from __future__ import annotations

import numpy as np

from conftest import dense_quadprog, highs_feasible, kkt_gap, standing_controller
from wbc.configuration import Configuration
from wbc.constraints import ContactConstraint
from wbc.solvers import DaqpBackend

DT = 0.01


def _swaying_on_daqp(robots, *extra_constraints):
    """(robot, config, controller): a standing Talos on the DAQP backend whose CoM target is 3 cm forward and 2 cm to
    the side, the second-order contact hold off (the command is then the assembled QP's optimum itself)."""
    robot = robots("talos")
    config = Configuration(robot)
    ctrl, com = standing_controller(robot, config, *extra_constraints)
    ctrl.backend = DaqpBackend()
    ctrl.contact_correction, ctrl.sole_drift_tolerance = 0.0, None
    com.set_target(config.com + np.array([0.03, -0.02, 0.0]))
    return robot, config, ctrl


def _assembled(ctrl, robot, q):
    return tuple(np.array(a, copy=True) for a in ctrl.assemble(Configuration(robot, q), DT))


def test_general_route_answers_the_optimum_of_the_assembled_qp(robots):
    """20 ticks of a CoM sway on DAQP: each command is quadprog's optimum of the assembled QP within 1e-6 (rad/s,
    m/s) and meets its KKT conditions to 1e-7."""
    robot, config, ctrl = _swaying_on_daqp(robots)
    for _ in range(20):
        q = config.q.copy()
        res = ctrl.solve(config, DT)
        assert res.ok and res.path == "general:daqp", (res.path, res.message)
        qp = _assembled(ctrl, robot, q)
        ref = dense_quadprog(*qp)
        assert np.abs(res.v - ref).max() < 1e-6, np.abs(res.v - ref).max()
        assert kkt_gap(*qp, res.v) < 1e-7, kkt_gap(*qp, res.v)
        config.update(config.integrate(res.v, DT))


def test_dependent_equality_rows_are_dropped_and_still_held(robots):
    """The left sole given twice as a contact: 6 equality rows repeated (A rank deficient; quadprog refuses such a
    QP). The route's command holds every row of A within 1e-9 (``dependent_residual`` likewise, ≤ the
    ``dependent_row_tolerance``) and is quadprog's optimum of the QP with the repeated rows removed (within 1e-6)."""
    robot = robots("talos")
    twin = ContactConstraint(robot, robot.left_sole)
    twin.set_placement_from_configuration(Configuration(robot))
    robot, config, ctrl = _swaying_on_daqp(robots, twin)
    for _ in range(5):
        q = config.q.copy()
        res = ctrl.solve(config, DT)
        assert res.ok and res.path == "general:daqp", (res.path, res.message)
        H, g, A, b, C, l, u, lb, ub = _assembled(ctrl, robot, q)
        _, first = np.unique(np.hstack([A, b[:, None]]), axis=0, return_index=True)
        assert first.size == A.shape[0] - 6  # the twin's rows are repeats
        keep = np.sort(first)
        ref = dense_quadprog(H, g, A[keep], b[keep], C, l, u, lb, ub)
        assert np.abs(A @ res.v - b).max() < 1e-9
        assert ctrl.dependent_residual <= min(1e-9, ctrl.dependent_row_tolerance)
        assert np.abs(res.v - ref).max() < 1e-6, np.abs(res.v - ref).max()
        config.update(config.integrate(res.v, DT))



def test_nearly_consistent_dependent_rows_are_accepted_within_their_tolerance(robots):
    """The left sole's twin contact placed 5 µm off the sole: its 6 rows repeat the sole's in A but ask another
    velocity (the equalities have no common solution: the hard set is empty, as HiGHS's LP confirms). The route keeps
    one copy of each row and accepts the other's residual, as long as it is within ``dependent_row_tolerance``: the
    tick is ok, ``dependent_residual`` is the largest |A v − b| (numpy, to 1e-12), between 1e-6 and the tolerance,
    and the command is quadprog's optimum of the QP with one of the two copies removed (within 1e-6)."""
    robot = robots("talos")
    twin = ContactConstraint(robot, robot.left_sole)
    off = Configuration(robot).frame_placement(twin.frame_id).copy()
    off.translation += [5e-6, 0.0, 0.0]
    twin.set_placement(off)
    robot, config, ctrl = _swaying_on_daqp(robots, twin)
    q = config.q.copy()
    res = ctrl.solve(config, DT)
    assert res.ok and res.path == "general:daqp", (res.path, res.message)
    H, g, A, b, C, l, u, lb, ub = _assembled(ctrl, robot, q)
    assert not highs_feasible(A, b, C, l, u, lb, ub)
    residual = np.abs(A @ res.v - b).max()
    assert abs(ctrl.dependent_residual - residual) < 1e-12
    assert 1e-6 < residual <= ctrl.dependent_row_tolerance, residual
    _, first = np.unique(A, axis=0, return_index=True)
    _, last = np.unique(A[::-1], axis=0, return_index=True)
    gaps = [np.abs(res.v - dense_quadprog(H, g, A[keep], b[keep], C, l, u, lb, ub)).max()
            for keep in (np.sort(first), np.sort(A.shape[0] - 1 - last))]
    assert min(gaps) < 1e-6, gaps
