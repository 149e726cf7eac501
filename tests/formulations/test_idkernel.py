"""The compiled ID tick (``solver="fast"``, :mod:`wbc.formulations.idkernel`) solves the same QP as the general path.

Independent references: DAQP on the numpy-assembled QP of :meth:`InverseDynamicsQP.build` (objective value and
solution), and the constraint rows of that assembly evaluated at the kernel's solution (feasibility), plus the
equations of motion M v̇ + h = Sᵀτ + J_cᵀ f recomputed with Pinocchio's RNEA.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin
import pytest
import quadprog

from wbc.dynamics import IDBalanceController
from wbc.formulations.idkernel import inverse_diagonal


def _quadprog(H, g, A, b, C, l, u, lb, ub):
    live = np.any(C[:, lb != ub] != 0.0, axis=1)  # rows on fixed variables only (0 ≤ 0) are left out
    C, l, u = C[live], l[live], u[live]
    rows = [C[np.isfinite(u)], -C[np.isfinite(l)]]
    rhs = [u[np.isfinite(u)], -l[np.isfinite(l)]]
    eye = np.eye(H.shape[0])
    fixed = lb == ub  # forces of a released contact: equalities
    rows += [eye[np.isfinite(ub) & ~fixed], -eye[np.isfinite(lb) & ~fixed]]
    rhs += [ub[np.isfinite(ub) & ~fixed], -lb[np.isfinite(lb) & ~fixed]]
    # quadprog: min ½xᵀGx − aᵀx s.t. Cᵀx ≥ b, the first meq equalities
    Ae = np.vstack([A, eye[fixed]])
    Cq = np.vstack([Ae, -np.vstack(rows)]).T
    bq = np.concatenate([b, lb[fixed], -np.concatenate(rhs)])
    return quadprog.solve_qp(H, -g, Cq, bq, Ae.shape[0])[0]


def _objective(qp, H, g, dv, f):
    x = np.concatenate([dv, f])
    return 0.5 * x @ H @ x + g @ x


@pytest.mark.parametrize("robot_name", ["talos", "g1"])
def test_kernel_matches_general_path(robots, robot_name):
    """States from the fast controller's own motion (integrating its v̇, as ``wbc bench``): a 3 cm lateral CoM
    sway on both soles, then single support on the right sole (left contact released, swing-foot task on)."""
    robot = robots(robot_name)
    dt = 0.002
    fast = IDBalanceController(robot, solver="fast", dt=dt)
    ref = IDBalanceController(robot, solver="daqp", dt=dt)
    q, v = robot.q_ref.copy(), np.zeros(robot.nv)
    for c in (fast, ref):
        c.reset(q, v)
    com0 = fast.state.com.copy()
    right_y = fast.state.data.oMf[robot.model.getFrameId(robot.right_sole)].translation[1]
    checked = 0
    ticks = 0
    for k in range(400):
        if k < 100:  # sway
            target = com0 + np.array([0.0, 0.03 * np.sin(np.pi * k * dt), 0.0])
        else:  # smooth shift over the right sole in 0.5 s, then single support
            s = min((k - 100) / 250.0, 1.0)
            target = com0 + np.array([0.0, (right_y - com0[1]) * (3 * s * s - 2 * s ** 3), 0.0])
        if k == 360:
            for c in (fast, ref):
                c.release_foot("left")
        for c in (fast, ref):
            c.set_com_reference(target)
        solves_before = fast.qp.chain.compiled.solves
        a = fast.solve(q, v)
        compare = k % 10 == 0
        b = ref.solve(q, v)  # the same measured state, every tick (release_foot reads the last state)
        q_meas, v_meas = q.copy(), v.copy()
        v = v + a.dv * dt
        q = pin.integrate(robot.model, q, v * dt)
        if not compare:
            continue
        ticks += 1
        assert a.ok and b.ok and not a.relaxed and not b.relaxed
        if fast.qp.chain.compiled.solves == solves_before:
            continue  # this tick went to the DAQP fallback: nothing compiled to compare
        checked += 1
        # the numpy assembly at the same state, solved by DAQP (b), is the reference QP
        H, g, A, bb, C, l, u, lb, ub = ref.qp.build(ref.state, ref.dt)
        x = np.concatenate([a.dv, a.forces])
        assert np.max(np.abs(A @ x - bb)) < 1e-6
        cx = C @ x
        assert np.all(cx >= l - 1e-6) and np.all(cx <= u + 1e-6)
        assert np.all(x >= lb - 1e-9) and np.all(x <= ub + 1e-9)
        # exact reference optimum: quadprog (Goldfarb–Idnani dual active set) on the numpy-assembled QP
        xr = _quadprog(H, g, A, bb, C, l, u, lb, ub)
        fa, fr = _objective(ref.qp, H, g, a.dv, a.forces), 0.5 * xr @ H @ xr + g @ xr
        assert abs(fa - fr) <= 1e-9 * max(1.0, abs(fr))
        assert np.max(np.abs(a.dv - xr[:robot.nv])) < 1e-6
        assert np.max(np.abs(a.dv - b.dv)) < 1e-5  # DAQP (primal tolerance 1e-6) on the same QP
        # equations of motion with Pinocchio's RNEA: τ_all = rnea(q, v, v̇) − J_cᵀ f
        tau_full = pin.rnea(robot.model, robot.model.createData(), q_meas, v_meas, a.dv) - \
            ref.qp.contact_jacobian_transpose @ a.forces
        assert np.max(np.abs(tau_full[:6])) < 1e-6
        assert np.max(np.abs(tau_full[6:] - a.tau)) < 1e-6
        for side in a.wrenches:
            assert np.max(np.abs(a.wrenches[side] - ref.qp.contacts[["left", "right"].index(side)].world_wrench(
                ref.state, a.forces[12 * ["left", "right"].index(side):12 * ["left", "right"].index(side) + 12]))) \
                < 1e-9
    assert checked >= ticks // 2, f"only {checked} of {ticks} compared ticks solved by the kernel"


@pytest.mark.parametrize("robot_name", ["talos", "g1"])
def test_kernel_equals_daqp_every_tick(robots, robot_name):
    """The compiled tick (``solver="fast"``) and the general path — the numpy assembly solved by DAQP's workspace
    (an exact active-set solve; not the one-shot dual warm start of the ``daqp`` default, which stops within its
    primal tolerance, ≈ 3e-7 from the optimum on these QPs) — at the same measured state on every one of 300
    ticks of the fast controller's own closed loop (v ← v + v̇ dt, q ← q ⊕ v dt): CoM sway on both soles, a
    joint-velocity kick at tick 100 (N(0, 0.5) rad/s, seed 0) that saturates torque limits and friction /
    normal-force constraints, the left sole released at tick 200. v̇ and forces agree to 1e-9 (relative to the
    largest entry, ≥ 1), no compiled tick falls back, and the kicked ticks have active inequalities.

    Closed-loop trajectories of two exact solvers are not compared: this loop amplifies a 1e-15 difference in v
    to 1e-6 within 30 ticks (measured with DAQP against itself), so a trajectory comparison measures the loop,
    not the solver."""
    robot = robots(robot_name)
    dt = 0.002
    fast = IDBalanceController(robot, solver="fast", dt=dt)
    # the kernel's iteration cap follows the tick budget (20 at the default 2 ms: ticks that need more go to
    # DAQP); this test compares the kernel's own answers, so its cap is the unbudgeted 100
    fast.controller.budget = math.inf
    assert fast.qp.kernel_max_iterations == 100
    ref, kick, q, v, com0 = _sway_reference(robot, fast, dt)
    active_ticks = 0
    worst = 0.0
    for k in range(300):
        if k == 100:
            v = v + kick
        if k == 200:
            for c in (fast, ref):
                c.release_foot("left")
        target = com0 + np.array([0.0, 0.02 * np.sin(np.pi * k * dt), 0.0])
        for c in (fast, ref):
            c.set_com_reference(target)
        a = fast.solve(q, v)
        b = ref.solve(q, v)
        assert a.ok and b.ok and not a.relaxed and not b.relaxed
        xa = np.concatenate([a.dv, a.forces])
        xb = np.concatenate([b.dv, b.forces])
        worst = max(worst, np.max(np.abs(xa - xb)) / max(1.0, np.max(np.abs(xb))))
        H, g, A, bb, C, l, u, lb, ub = ref.qp.build(ref.state, dt)
        cx = C @ xb
        free = lb < ub
        if np.any(np.abs(cx - u) < 1e-9) or np.any(free & (np.abs(xb - lb) < 1e-9)):
            active_ticks += 1
        v = v + a.dv * dt
        q = pin.integrate(robot.model, q, v * dt)
    assert fast.qp.chain.compiled.fallbacks == 0
    assert active_ticks >= 20, active_ticks
    assert worst < 1e-9, worst


@pytest.mark.parametrize("robot_name", ["talos", "g1", "humanoid15"])
def test_contact_conditioning_certificate_is_sound(robots, robot_name):
    """The compiled certificate that lets the kernel path skip ``consistent_contact_rhs`` never certifies stacked
    sole rows whose smallest singular value (numpy SVD) is below 1e-2 × the largest, and it certifies Talos and
    G1 (6-DoF legs) at every sampled stance (random joint offsets N(0, 0.1) rad, seed 1)."""
    from wbc.formulations.idkernel import contact_rows_well_conditioned

    robot = robots(robot_name)
    model, data = robot.model, robot.model.createData()
    rng = np.random.default_rng(1)
    certified = 0
    for k in range(30):
        dq = np.zeros(model.nv)
        if k:
            dq[6:] = rng.normal(0.0, 0.1, model.nv - 6)
        q = pin.integrate(model, robot.q_ref, dq)
        pin.computeJointJacobians(model, data, q)
        pin.framesForwardKinematics(model, data, q)
        Jc = np.array([pin.getFrameJacobian(model, data, robot.frame_id(f), pin.LOCAL)
                       for f in (robot.left_sole, robot.right_sole)])
        s = np.linalg.svd(Jc.reshape(12, -1), compute_uv=False)
        cert = contact_rows_well_conditioned(Jc, np.ones(2, np.bool_), 1e-2, np.zeros((12, 12)), np.zeros(12))
        if cert:
            certified += 1
            assert s[-1] >= 1e-2 * s[0]
    if robot_name != "humanoid15":
        assert certified == 30


def test_kernel_iteration_cap_follows_the_budget_and_daqp_answers_a_capped_tick(robots):
    """The compiled tick's iteration cap is a count set by the tick budget (40 at 4 ms, 20 at 2 ms, 4 at 0.4 ms and
    below, 100 unbounded). On Talos' kicked sway loop (the loop of ``test_kernel_equals_daqp_every_tick``) the kick's
    tick needs 5 iterations: at a 2 ms budget the kernel answers it; at 0.4 ms (cap 4) that tick is answered by DAQP on
    the same assembly, and the next tick by the kernel again, started from DAQP's working set (no tick skips it).
    Every answer agrees with the reference DAQP workspace solve to 1e-6 (DAQP's dual one-shot stops within its
    primal tolerance)."""
    from wbc.solvers.compiled_id import kernel_iterations

    assert kernel_iterations(0.004) == 40 and kernel_iterations(0.002) == 20 and kernel_iterations(0.0004) == 4
    assert kernel_iterations(1e-5) == 4
    assert kernel_iterations(math.inf) == 100
    robot = robots("talos")
    dt = 0.002
    for budget, expected in ((0.002, []), (0.0004, [100])):
        fast = IDBalanceController(robot, solver="fast", dt=dt)
        fast.controller.budget = budget
        ref, kick, q, v, com0 = _sway_reference(robot, fast, dt)
        paths = []
        for k in range(160):
            if k == 100:
                v = v + kick
            for c in (fast, ref):
                c.set_com_reference(com0 + np.array([0.0, 0.02 * np.sin(np.pi * k * dt), 0.0]))
            a, b = fast.solve(q, v), ref.solve(q, v)
            assert a.ok and b.ok and not a.relaxed
            xa, xb = np.concatenate([a.dv, a.forces]), np.concatenate([b.dv, b.forces])
            assert np.max(np.abs(xa - xb)) / max(1.0, np.max(np.abs(xb))) < 1e-6
            paths.append(a.path)
            v = v + a.dv * dt
            q = pin.integrate(robot.model, q, v * dt)
        capped = [k for k, p in enumerate(paths) if p != "kernel"]
        assert capped == expected, (budget, capped)  # the kick's tick: past 4 iterations, within 20
        for k in capped:
            assert paths[k] == "general:fast"


def _sway_reference(robot, fast, dt):
    """(reference DAQP controller, joint velocity kick (nv,), q, v, CoM (3,) m) of the kicked sway loop: both
    controllers reset at the reference posture, at rest."""
    from wbc.solvers import make_backend

    ref = IDBalanceController(robot, solver=make_backend("daqp", primal_tol=1e-6), dt=dt)
    nv = robot.nv
    kick = np.zeros(nv)
    kick[6:] = np.random.default_rng(0).normal(0.0, 0.5, nv - 6)
    q, v = robot.q_ref.copy(), np.zeros(nv)
    for c in (fast, ref):
        c.reset(q, v)
    return ref, kick, q, v, fast.state.com.copy()


def test_the_compiled_assembly_takes_its_arguments_as_six_namedtuples():
    """id_assemble's positional parameters: the task rows, the dynamics, the contacts, the limits, the QP arrays, the
    workspace (namedtuples of :mod:`wbc.formulations.idkernel`), at most 10."""
    import inspect

    from wbc.formulations import idkernel
    params = list(inspect.signature(idkernel.id_assemble.py_func).parameters)
    assert params == ["tasks", "dynamics", "contacts", "limits", "qp", "work"]
    assert [f for t in (idkernel.IDTaskRows, idkernel.IDDynamics, idkernel.IDContactData, idkernel.IDLimits,
                        idkernel.IDArrays, idkernel.IDAssemblyWork) for f in t._fields][:5] == ["Jt", "R", "pidx", "rt", "M"]


# The output check (IDOutputCheck) on the compiled tick's answer for Talos standing, perturbed by hand one constraint
# at a time. Oracles: Pinocchio (the generalized gravity h at the state); each violation in closed form.
OC_DT = 0.002
OC_TOL = 1e-6


def _standing_solution(robots):
    robot = robots("talos")
    ctrl = IDBalanceController(robot, dt=OC_DT)
    ctrl.reset(robot.q_ref.copy(), np.zeros(robot.nv))
    ctrl.state.update(robot.q_ref.copy(), np.zeros(robot.nv))
    sol = ctrl.qp.solve(ctrl.state, OC_DT)
    h = pin.computeGeneralizedGravity(robot.model, robot.model.createData(), robot.q_ref)  # v = 0: h is gravity alone
    return robot, ctrl.qp, sol, h


def test_the_compiled_answer_passes_and_a_torque_past_its_limit_is_named_with_its_excess(robots):
    robot, qp, sol, h = _standing_solution(robots)
    check = qp.output_check
    assert check.violations(h, sol, OC_TOL, relaxed=False) == []
    tl = qp.torque_limits
    j, limit = int(tl.joints[0]), float(tl.limits[0])
    assert np.isfinite(limit) and limit > 0
    tau = sol.tau.copy()
    tau[j] = limit + 2.0  # 2 N·m past its limit, nothing else changed
    found = check.violations(h, dataclasses.replace(sol, tau=tau), OC_TOL, relaxed=False)
    assert [name for name, _ in found] == ["torque_limits"], found
    assert abs(found[0][1] - 2.0) < 1e-9 * max(1.0, limit), found
    # relaxed: the torque limits are not checked (the relaxed QP drops them)
    assert "torque_limits" not in dict(check.violations(h, dataclasses.replace(sol, tau=tau), OC_TOL, relaxed=True))


def test_a_pulling_corner_force_is_a_unilaterality_violation_of_its_contact(robots):
    robot, qp, sol, h = _standing_solution(robots)
    forces = sol.forces.copy()
    forces[2] = -5.0  # first contact, first corner: f_z = -5 N (pulls), bound f_z >= 0
    found = dict(qp.output_check.violations(h, dataclasses.replace(sol, forces=forces), OC_TOL, relaxed=True))
    name = f"unilaterality:{qp.contacts[0].name}"
    assert name in found and abs(found[name] - 5.0) < 1e-9, found


def test_a_residual_of_the_equations_of_motion_is_a_floating_base_violation(robots):
    """The check compares the solution's stated residual ‖M v̇ + h − Sᵀτ − J_cᵀ f‖_∞ with the tolerance times the
    largest |h| entry of the base rows: 1 N of residual at Talos's weight is a violation, of 1 N."""
    robot, qp, sol, h = _standing_solution(robots)
    assert OC_TOL * np.abs(h[:6]).max() < 1.0  # 1 N is past the tolerance on this scale
    found = dict(qp.output_check.violations(h, dataclasses.replace(sol, dynamics_residual=1.0), OC_TOL, relaxed=True))
    assert found.get("floating_base_dynamics") == 1.0, found


def test_a_non_finite_entry_is_none_not_a_list(robots):
    _, qp, sol, h = _standing_solution(robots)
    tau = sol.tau.copy()
    tau[0] = np.nan
    assert qp.output_check.violations(h, dataclasses.replace(sol, tau=tau), OC_TOL, relaxed=False) is None


def test_inverse_diagonal_against_numpy():
    """diag(M⁻¹) of the compiled Cholesky kernel against numpy's inverse on random symmetric positive definite
    matrices (condition up to ~1e6) to 1e-9 relative; a matrix that is not positive definite is declined."""
    rng = np.random.default_rng(3)
    for n in (1, 7, 38):
        Q = np.linalg.qr(rng.normal(size=(n, n)))[0]
        M = np.asfortranarray((Q * np.logspace(0, 6, n)) @ Q.T)
        out = np.empty(n)
        assert inverse_diagonal(M, np.empty((n, n)), np.empty(n), out)
        ref = np.diag(np.linalg.inv(M))
        assert np.abs(out - ref).max() <= 1e-9 * np.abs(ref).max()
        M[0, 0] = -1.0
        assert not inverse_diagonal(M, np.empty((n, n)), np.empty(n), out)
