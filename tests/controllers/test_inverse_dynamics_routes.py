"""Every route of an inverse-dynamics tick (wbc.tick.ID_ROUTES) is reached, each tick saying in
``IDCommand.path_reason`` why it left the compiled route and which step of the fallback chain answered."""

from __future__ import annotations

import numpy as np

from wbc.dynamics import AccelerationReference, InverseDynamicsController, InverseDynamicsQP, SoleContact
from wbc.dynamics.balance import IDBalanceController
from wbc.exceptions import SolverError
from wbc.solvers.status import SolverStatus
from wbc.tasks import PostureTask
from wbc.tick import ID_ROUTES

DT = 0.002


def _hard_posture_controller(robot, scale: float):
    """Every joint asked v̇ = 0 (hard), torque limits at ``scale`` × the URDF effort: at 0.2 the static torques need
    more (infeasible, tests/formulations/test_acceleration_diagnosis.py), feasible once the limits are relaxed."""
    posture = AccelerationReference(PostureTask(robot), kp=0.0, kd=0.0, name="posture")
    posture.set_target(robot.q_ref)
    soles = [SoleContact(robot, robot.left_sole, name="left"), SoleContact(robot, robot.right_sole, name="right")]
    qp = InverseDynamicsQP(robot, [], soles, torque_limit_scale=scale)
    qp.add_task(posture, hard=True)
    return InverseDynamicsController(qp, DT)


def test_every_id_route_is_reached_with_its_reason(robots):
    robot = robots("talos")
    q, v = robot.q_ref.copy(), np.zeros(robot.nv)
    reached = set()

    ctrl = IDBalanceController(robot, dt=DT)
    ctrl.reset(q, v)
    kernel = ctrl.solve(q, v)
    assert kernel.ok and kernel.path == "kernel" and kernel.path_reason == ""
    reached.add(kernel.path.route)

    # the compiled call reports its iteration cap: the chain (its backend: DAQP) answers the arrays it assembled
    compiled = ctrl.qp.chain.compiled
    call = compiled.solve

    def failing(status):
        def solve(qp):
            call(qp)
            raise SolverError(compiled.status_text(int(status), 0.0))
        return solve

    compiled.solve = failing(SolverStatus.ITERATION_CAP)
    general = ctrl.solve(q, v)
    compiled.solve = call
    assert general.ok and general.path == "general:fast"  # the backend named "fast": DAQP without kernel rows
    assert general.path_reason == "kernel status ITERATION_CAP → fast attempt"
    # the same QP (same state, same targets) answered by another solver: DAQP's primal tolerance is 1e-6
    assert np.abs(general.tau - kernel.tau).max() < 1e-3 * max(1.0, np.abs(kernel.tau).max())
    reached.add(general.path.route)

    relaxed_ctrl = _hard_posture_controller(robot, 0.2)
    relaxed = relaxed_ctrl.solve(q, v)
    assert relaxed.ok and relaxed.relaxed and relaxed.path.route == "relaxed"
    assert relaxed.path_reason.startswith("full QP failed → relaxed QP, ")
    reached.add(relaxed.path.route)

    # feasible, but every joint held and both soles fixed make the kernel's working rows dependent: it says so
    held = _hard_posture_controller(robot, 1.0).solve(q, v)
    assert held.ok and held.path == "general:fast" and held.path_reason == "kernel status DEPENDENT_ROWS → fast attempt"

    class Broken:
        name = "broken"
        tolerance = 1e-6

        def solve(self, *args):
            raise SolverError("broken on purpose")

    ctrl.qp.backend = Broken()
    compiled.solve = failing(SolverStatus.INFEASIBLE)
    hold = ctrl.solve(q, v)  # the last tick was solved: its command is held
    assert not hold.ok and hold.path == "fallback:hold" and hold.path_reason == "full and relaxed QP failed → hold"
    gravity = ctrl.solve(q, v)  # a second failed tick in a row
    assert gravity.path == "fallback:gravity" and gravity.path_reason == "full and relaxed QP failed → gravity"
    reached.add(gravity.path.route)
    assert reached == set(ID_ROUTES)
