"""The centroidal angular momentum rate bound (wbc.constraints.momentum_rate): its rows give Pinocchio's L̇
(``computeCentroidalMomentumTimeVariation``, an independent recursive algorithm) at any x = [v̇; f], and l ≤ C x ≤ u
holds exactly when |L̇| ≤ L̇_max; added to a Talos InverseDynamicsController it binds, its ticks stay on the compiled
route (``path`` is ``kernel``), and the compiled answer is quadprog's optimum of the QP that ``build`` assembles."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from conftest import assert_id_command_is_the_qp_optimum, id_ticks_from_standing, written_id_rows
from wbc.constraints import AngularMomentumRateBound
from wbc.dynamics import AccelerationReference, InverseDynamicsController, InverseDynamicsQP, SoleContact
from wbc.exceptions import InvalidInputError
from wbc.tasks import PostureTask

DT = 0.002
LIMIT = np.array([30.0, 25.0, 20.0])  # N·m, world x, y, z
#: the rows against Pinocchio's L̇, relative to the largest L̇ (round-off of two centroidal computations)
ROW_TOL = 1e-9
#: the compiled answer against quadprog's on the same QP (rad/s², N), relative: both are exact active-set solvers
X_TOL = 1e-6


def _momentum_rate(robot, q, v, dv) -> np.ndarray:
    data = robot.model.createData()
    pin.computeCentroidalMomentumTimeVariation(robot.model, data, q, v, dv)
    return data.dhg.angular.copy()


def test_rows_are_pinocchios_momentum_rate_against_the_limit(robots):
    robot = robots("talos")
    rng = np.random.default_rng(59)
    nf = 24
    con = AngularMomentumRateBound(LIMIT)
    checked = {True: 0, False: 0}
    for q, v, C, l, u in written_id_rows(robot, con, rng, DT, nf=nf):
        for scale in (0.01, 0.3, 30.0):  # |L̇| inside the limit, near it, far outside
            dv = scale * rng.standard_normal(robot.nv)
            x = np.concatenate([dv, rng.standard_normal(nf)])
            rate = _momentum_rate(robot, q, v, dv)
            Cx = C @ x
            np.testing.assert_allclose(Cx - l, rate + LIMIT, rtol=0, atol=ROW_TOL * max(1.0, abs(rate).max()))
            np.testing.assert_allclose(u - Cx, LIMIT - rate, rtol=0, atol=ROW_TOL * max(1.0, abs(rate).max()))
            inside = bool((np.abs(rate) <= LIMIT).all())
            assert bool(((l <= Cx) & (Cx <= u)).all()) == inside
            checked[inside] += 1
    assert checked[True] and checked[False]  # both sides of the bound were met


def _turning_torso(robot, bound: AngularMomentumRateBound | None) -> InverseDynamicsController:
    """Talos on both soles, a stiff posture task asking the torso to yaw by 0.5 rad (a large L̇_z), the bound added
    in one line when given."""
    posture = AccelerationReference(PostureTask(robot), kp=400.0, kd=40.0, name="posture")
    target = robot.q_ref.copy()
    target[robot.model.joints[robot.model.getJointId("torso_1_joint")].idx_q] += 0.5
    posture.set_target(target)
    soles = [SoleContact(robot, robot.left_sole, name="left"), SoleContact(robot, robot.right_sole, name="right")]
    ctrl = InverseDynamicsController(InverseDynamicsQP(robot, [posture], soles), DT)
    if bound is not None:
        ctrl.qp.add_constraint(bound)
    return ctrl


def _run(robot, ctrl):
    """20 ticks from standing; per tick the command and Pinocchio's L̇ under it."""
    return id_ticks_from_standing(robot, ctrl, 20, DT, lambda q, v, dv: _momentum_rate(robot, q, v, dv))


def test_on_a_talos_controller_it_binds_and_stays_on_the_compiled_path(robots):
    robot = robots("talos")
    free = _run(robot, _turning_torso(robot, None))
    assert max(abs(rate[2]) for _, rate in free) > 2 * LIMIT[2]  # the task alone asks far more than the bound
    bound = AngularMomentumRateBound(LIMIT)
    ctrl = _turning_torso(robot, bound)
    held = _run(robot, ctrl)
    # the first tick is cold (no warm start) and leaves the compiled route with or without the bound
    assert str(held[0][0].path) == str(free[0][0].path)
    for k, (cmd, rate) in enumerate(held):
        assert (np.abs(rate) <= LIMIT * (1 + 1e-6)).all(), (k, rate)
        assert abs(abs(rate[2]) - LIMIT[2]) <= 1e-6 * LIMIT[2], (k, rate)  # it binds on z
        if k:
            assert str(cmd.path) == "kernel" and cmd.path_reason == "", (k, cmd.path, cmd.path_reason)
    assert ctrl.paths["kernel"] == 19
    # the compiled answer of the last tick is the optimum of the QP build() assembles there, the bound's rows in it
    C = assert_id_command_is_the_qp_optimum(ctrl, held[-1][0], DT, X_TOL)
    np.testing.assert_array_equal(C[bound.rows, :robot.nv], ctrl.state.centroidal_momentum_matrix[3:6])


@pytest.mark.parametrize("limit", [0.0, -1.0, math.nan, [1.0, 2.0], "big", [1.0, -2.0, 3.0]])
def test_bad_limit_is_a_typed_error(limit):
    with pytest.raises(InvalidInputError, match="angular_momentum_rate: limit must be"):
        AngularMomentumRateBound(limit)


def test_a_free_axis_and_a_new_limit():
    bound = AngularMomentumRateBound([math.inf, 10.0, 10.0])
    assert bound.limit[0] == math.inf
    bound.set_limit(5.0)
    np.testing.assert_array_equal(bound.limit, [5.0, 5.0, 5.0])
    bound.limit[:] = 1.0  # a copy: the bound is unchanged
    np.testing.assert_array_equal(bound.limit, [5.0, 5.0, 5.0])


def test_assigning_the_limit_validates_it():
    bound = AngularMomentumRateBound(10.0)
    bound.limit = [1.0, 2.0, math.inf]
    np.testing.assert_array_equal(bound.limit, [1.0, 2.0, math.inf])
    with pytest.raises(InvalidInputError, match="limit must be > 0"):
        bound.limit = [1.0, math.nan, 1.0]
    np.testing.assert_array_equal(bound.limit, [1.0, 2.0, math.inf])  # unchanged by the refused value
