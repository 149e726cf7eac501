"""Inverse-dynamics infeasibility diagnosis and safe command (issue 9).

A task held as a hard equality asks for more than the friction pyramids or the torque limits allow. The tick must
return a finite command within the URDF torque limits and name the conflicting constraints. Independent references:
the closed-form friction bound (the total tangential force of the inscribed pyramids is at most μ/√2 · m g when the
CoM may not accelerate vertically) and HiGHS (scipy ``linprog``) declaring the hard set infeasible with the named
constraint and feasible without it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.optimize as so

from wbc.dynamics import (
    AccelerationReference,
    InverseDynamicsController,
    InverseDynamicsQP,
    SoleContact,
)
from wbc.tasks import ComTask, PostureTask

DT = 0.002
G = 9.81


def _lp_status(qp, state, drop: str | None = None) -> int:
    """HiGHS status of the feasibility LP of the QP's hard set (0 feasible, 2 infeasible); constraints whose name
    starts with ``drop`` are left out."""
    _, _, A, b, C, l, u, lb, ub = qp.build(state, DT)
    l, u, lb, ub = l.copy(), u.copy(), lb.copy(), ub.copy()
    for con in qp.constraints:
        if drop is not None and con.name.startswith(drop):
            if con.kind == "inequality":
                l[con.rows], u[con.rows] = -np.inf, np.inf
            elif con.kind == "bounds":
                lb[con.indices], ub[con.indices] = -np.inf, np.inf
    fu, fl = np.isfinite(u), np.isfinite(l)
    bounds = [(lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None) for lo, hi in zip(lb, ub)]
    res = so.linprog(np.zeros(qp.n), A_ub=np.vstack([C[fu], -C[fl]]), b_ub=np.concatenate([u[fu], -l[fl]]),
                     A_eq=A, b_eq=b, bounds=bounds, method="highs")
    return res.status


def _soles(robot, mu):
    return [SoleContact(robot, robot.left_sole, name="left", mu=mu),
            SoleContact(robot, robot.right_sole, name="right", mu=mu)]


def _check_safe(cmd, qp):
    assert np.isfinite(cmd.tau).all() and np.isfinite(cmd.dv).all()
    assert np.all(np.abs(cmd.tau) <= qp.tau_max + 1e-9), "command exceeds the URDF torque limits"


@pytest.mark.parametrize("lateral, feasible", [(2.0, True), (3.0, False)])
def test_hard_com_acceleration_against_friction_pyramids(robots, lateral, feasible):
    robot = robots("talos")
    mu = 0.3
    # closed form: largest lateral CoM acceleration the inscribed pyramids allow with zero vertical acceleration
    a_max = mu / math.sqrt(2.0) * G
    assert (lateral < a_max) == feasible
    com = AccelerationReference(ComTask(), kp=0.0, kd=0.0, name="com")
    qp = InverseDynamicsQP(robot, [AccelerationReference(PostureTask(robot), kp=50.0)], _soles(robot, mu))
    qp.add_task(com, hard=True)
    com.set_target(np.zeros(3))
    com.set_feedforward_acceleration([0.0, lateral, 0.0])
    ctrl = InverseDynamicsController(qp, DT, diagnose=True)  # diagnosis mode: conflicts named in the tick
    cmd = ctrl.solve(robot.q_ref, np.zeros(robot.nv))
    _check_safe(cmd, qp)
    if feasible:
        assert cmd.ok and not cmd.conflicts and _lp_status(qp, ctrl.state) == 0
        return
    names = [n for n, _ in cmd.conflicts]
    assert {"task:com", "friction:left", "friction:right"} <= set(names), names
    assert "torque_limits" not in names
    assert "friction:left" in cmd.message
    assert _lp_status(qp, ctrl.state) == 2  # infeasible (HiGHS)
    assert _lp_status(qp, ctrl.state, drop="friction") == 0  # feasible without the pyramids
    assert not cmd.ok  # friction is not relaxable: the safe gravity-compensation command
    assert all(np.isfinite(w).all() for w in cmd.wrenches.values())


def test_hard_posture_against_torque_limits(robots):
    robot = robots("talos")
    posture = AccelerationReference(PostureTask(robot), kp=0.0, kd=0.0, name="posture")  # every joint v̇ = 0
    posture.set_target(robot.q_ref)
    qp = InverseDynamicsQP(robot, [], _soles(robot, 0.7), torque_limit_scale=0.2)
    qp.add_task(posture, hard=True)
    # diagnosis mode, no time budget: this test is about the names and the relaxed command, not the tick's time
    ctrl = InverseDynamicsController(qp, DT, diagnose=True, budget=math.inf)
    cmd = ctrl.solve(robot.q_ref, np.zeros(robot.nv))
    _check_safe(cmd, qp)
    names = [n for n, _ in cmd.conflicts]
    assert {"torque_limits", "task:posture"} <= set(names), names
    assert not any(n.startswith("friction") for n in names)
    assert _lp_status(qp, ctrl.state) == 2
    assert _lp_status(qp, ctrl.state, drop="torque_limits") == 0
    # the relaxed QP (no torque / joint limits) gave the command, clipped to the limits it dropped
    assert cmd.ok and cmd.relaxed
    # the static torques needed exceed 0.2 × effort on some joint: the clip is active
    assert np.any(np.isclose(np.abs(cmd.tau), qp.tau_max))


def test_feasible_tick_reports_nothing(robots):
    robot = robots("talos")
    qp = InverseDynamicsQP(robot, [AccelerationReference(PostureTask(robot), kp=50.0)], _soles(robot, 0.7))
    ctrl = InverseDynamicsController(qp, DT, diagnose=True)  # diagnosis mode: conflicts named in the tick
    cmd = ctrl.solve(robot.q_ref, np.zeros(robot.nv))
    assert cmd.ok and not cmd.relaxed and cmd.conflicts == [] and cmd.message == ""
    # the diagnosis' ε‖x‖² (ε = 1e-8) against corner forces of ~100 N leaves slacks of order 1e-6 on a feasible
    # set: nothing above 1e-4 may be reported
    assert qp.diagnose(ctrl.state, DT, tol=1e-4) == []
    names = {c.name for c in qp.constraints}
    assert {"floating_base_dynamics", "contact:left", "contact:right", "torque_limits", "friction:left",
            "friction:right", "unilaterality:left", "unilaterality:right", "joint_limits"} <= names
