"""Constraints added to the inverse-dynamics QP are gathered entries of its one assembly (their ``write`` in
``InverseDynamicsQP.build``): the compiled tick (``solver="fast"``) solves the QP with their rows and its answer says
so (``IDCommand.path`` is ``kernel``). Oracles: quadprog (dense Goldfarb–Idnani, ``conftest``) on the QP
that :meth:`InverseDynamicsQP.build` assembles at the same state, and the constraint's own rows, written here."""

from __future__ import annotations

import numpy as np

from conftest import dense_quadprog
from wbc.constraints.base import IDConstraint
from wbc.dynamics.balance import IDBalanceController
from wbc.formulations.reference import AccelerationReference
from wbc.tasks import PostureTask

DT = 0.002
#: agreement of the compiled answer with quadprog's on the same QP (rad/s², N): both are exact active-set solvers
X_TOL = 1e-6


class SoleLoadCap(IDConstraint):
    """Σ corner normal forces of one sole ≤ ``cap`` (N): one inequality row on its 4 f_z, built here."""

    kind = "inequality"
    dim = 1

    def __init__(self, first_force_column: int, cap: float):
        self.name = "sole_load_cap"
        self.columns = np.arange(first_force_column + 2, first_force_column + 12, 3)  # f_z of the 4 corners
        self.cap = cap

    def write(self, ctx, C, l, u):
        C[:] = 0.0
        C[0, self.columns] = 1.0
        l[:] = -np.inf
        u[:] = self.cap


def _standing(robots):
    robot = robots("talos")
    ctrl = IDBalanceController(robot, dt=DT)
    ctrl.reset(robot.q_ref.copy(), np.zeros(robot.nv))
    return robot, ctrl


def _solve_both(ctrl, robot):
    """The compiled tick's solution at the reference state, and quadprog's x on build()'s QP there."""
    ctrl.state.update(robot.q_ref.copy(), np.zeros(robot.nv))
    sol = ctrl.qp.solve(ctrl.state, DT)
    H, g, A, b, C, l, u, lb, ub = ctrl.qp.build(ctrl.state, DT)
    return sol, np.concatenate([sol.dv, sol.forces]), dense_quadprog(H, g, A, b, C, l, u, lb, ub), (A, b, C, u)


def test_an_added_inequality_stays_on_the_compiled_path_and_binds(robots):
    robot, ctrl = _standing(robots)
    qp = ctrl.qp
    left = qp.contacts.index(qp.contact("left"))
    weight = robot.mass * 9.81
    sol0, x0, _, _ = _solve_both(ctrl, robot)
    assert str(sol0.path) == "kernel"
    assert x0[qp.nv + 12 * left:][2:12:3].sum() > 0.4 * weight  # standing: the left sole carries about half
    cap = SoleLoadCap(qp.nv + 12 * left, 0.3 * weight)
    qp.add_constraint(cap)
    sol, x, xq, (_, _, C, u) = _solve_both(ctrl, robot)
    assert str(sol.path) == "kernel", sol.path
    # the row build() wrote is the one defined here, and the answer meets it, at the cap (it binds)
    row = C[cap.rows][0]
    assert np.flatnonzero(row).tolist() == cap.columns.tolist() and u[cap.rows][0] == 0.3 * weight
    assert abs(x[cap.columns].sum() - 0.3 * weight) <= 1e-6 * weight
    np.testing.assert_allclose(x, xq, rtol=0, atol=X_TOL * max(1.0, np.abs(xq).max()))


def test_a_hard_task_stays_on_the_compiled_path(robots):
    robot, ctrl = _standing(robots)
    qp = ctrl.qp
    arm = PostureTask(robot, joints=[robot.model.names[robot.model.njoints - 1]])
    target = robot.q_ref.copy()
    target[-1] += 0.2
    arm.set_target(target)
    qp.add_task(AccelerationReference(arm, kp=100.0), hard=True)
    sol, x, xq, (A, b, _, _) = _solve_both(ctrl, robot)
    assert str(sol.path) == "kernel", sol.path
    assert A.shape[0] == 6 + 12 + 1  # the dynamics, two soles, the hard task's row
    np.testing.assert_allclose(A @ x, b, rtol=0, atol=1e-8 * max(1.0, np.abs(b).max()))
    np.testing.assert_allclose(x, xq, rtol=0, atol=X_TOL * max(1.0, np.abs(xq).max()))
