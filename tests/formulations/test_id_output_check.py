"""The inverse-dynamics output check (:class:`wbc.formulations.id_output_check.IDOutputCheck`), on a solution the
compiled tick gives Talos standing, perturbed by hand one constraint at a time. Oracles: Pinocchio (the generalized
gravity h at the state); each violation in closed form (the amount written here)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin

from wbc.dynamics.balance import IDBalanceController
from wbc.formulations.id_output_check import nonfinite_references

DT = 0.002
TOL = 1e-6


def _standing(robots):
    robot = robots("talos")
    ctrl = IDBalanceController(robot, dt=DT)
    ctrl.reset(robot.q_ref.copy(), np.zeros(robot.nv))
    ctrl.state.update(robot.q_ref.copy(), np.zeros(robot.nv))
    sol = ctrl.qp.solve(ctrl.state, DT)
    h = pin.computeGeneralizedGravity(robot.model, robot.model.createData(), robot.q_ref)  # v = 0: h is gravity alone
    return robot, ctrl.qp, sol, h


def test_the_compiled_answer_passes_and_a_torque_past_its_limit_is_named_with_its_excess(robots):
    robot, qp, sol, h = _standing(robots)
    check = qp.output_check
    assert check.violations(h, sol, TOL, relaxed=False) == []
    tl = qp.torque_limits
    j, limit = int(tl.joints[0]), float(tl.limits[0])
    assert np.isfinite(limit) and limit > 0
    tau = sol.tau.copy()
    tau[j] = limit + 2.0  # 2 N·m past its limit, nothing else changed
    found = check.violations(h, dataclasses.replace(sol, tau=tau), TOL, relaxed=False)
    assert [name for name, _ in found] == ["torque_limits"], found
    assert abs(found[0][1] - 2.0) < 1e-9 * max(1.0, limit), found
    # relaxed: the torque limits are not checked (the relaxed QP drops them)
    assert "torque_limits" not in dict(check.violations(h, dataclasses.replace(sol, tau=tau), TOL, relaxed=True))


def test_a_pulling_corner_force_is_a_unilaterality_violation_of_its_contact(robots):
    robot, qp, sol, h = _standing(robots)
    forces = sol.forces.copy()
    forces[2] = -5.0  # first contact, first corner: f_z = -5 N (pulls), bound f_z >= 0
    found = dict(qp.output_check.violations(h, dataclasses.replace(sol, forces=forces), TOL, relaxed=True))
    name = f"unilaterality:{qp.contacts[0].name}"
    assert name in found and abs(found[name] - 5.0) < 1e-9, found


def test_a_residual_of_the_equations_of_motion_is_a_floating_base_violation(robots):
    """The check compares the solution's stated residual ‖M v̇ + h − Sᵀτ − J_cᵀ f‖_∞ with the tolerance times the
    largest |h| entry of the base rows: 1 N of residual at Talos's weight is a violation, of 1 N."""
    robot, qp, sol, h = _standing(robots)
    assert TOL * np.abs(h[:6]).max() < 1.0  # 1 N is past the tolerance on this scale
    found = dict(qp.output_check.violations(h, dataclasses.replace(sol, dynamics_residual=1.0), TOL, relaxed=True))
    assert found.get("floating_base_dynamics") == 1.0, found


def test_a_non_finite_entry_is_none_not_a_list(robots):
    _, qp, sol, h = _standing(robots)
    tau = sol.tau.copy()
    tau[0] = np.nan
    assert qp.output_check.violations(h, dataclasses.replace(sol, tau=tau), TOL, relaxed=False) is None


def test_nonfinite_references_names_the_task_with_a_nan_weight():
    class Ref:
        def __init__(self, name, weight):
            self.name, self.weight = name, np.asarray(weight, float)
            self.last_error = np.zeros(3)
            self.feedforward_acceleration = None

    found = nonfinite_references([Ref("com", [1.0, 1.0, 1.0]), Ref("posture", [1.0, np.nan])])
    assert [name for name, _ in found] == ["task:posture"] and np.isnan(found[0][1])
