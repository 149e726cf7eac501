"""The compiled kernels of the kinematic QP (:mod:`wbc.formulations.velocity_kernel`): the cost formation and the
compiled solver against numpy and quadprog, and the frame distances (``translation_gap``, ``rotation_gap``, the
controller's sole drift) against Pinocchio's exponential and forward kinematics."""

from __future__ import annotations

import numpy as np
import pytest
import qpsolvers

from wbc.solvers import make_backend


@pytest.mark.parametrize("seed", range(30))
def test_compiled_tick_is_the_optimum_of_its_qp(seed):
    """wbc.formulations.velocity_kernel.form_qp (the cost from task rows with gains/weights/feed-forward, a posture
    diagonal, damping) against the cost written out here in numpy, and wbc.formulations.velocity_kernel.kinematic_solve
    (floating-base elimination + active set) on that assembled QP — equality rows whose first 6 are an invertible base
    block (on odd seeds zero on most joint columns, as a contact's Jacobian outside its chain), inequality rows, a
    velocity box with position limits clipped into it — against quadprog. When the kernel gives up (negative code)
    the full-space kernel must give up on that QP too."""
    from wbc.formulations.velocity_kernel import (form_qp, kinematic_pack, kinematic_solve, kinematic_views, rows_pack,
                                                  task_rows)

    rng = np.random.default_rng(500 + seed)
    nv = int(rng.integers(16, 40))
    nq = nv + 1
    mt, n_eq, n_in = int(rng.integers(1, 8)), 6 + 6 * int(rng.integers(0, 2)), int(rng.integers(0, 3))
    eliminate = seed % 3 != 0
    er = 0 if eliminate else -1
    joints = np.arange(6, nv)
    kl = joints.size
    fb, ib = kinematic_pack(nv, n_eq, n_in, er)
    x, _, ws, iws, _ = kinematic_views.py_func(fb, ib)
    Js = rng.standard_normal((mt, nv))
    es = rng.standard_normal(mt)
    rowp = np.array([rng.uniform(0, 2, mt), rng.uniform(0.1, 10, mt), 0.3 * rng.standard_normal(mt)])
    A = rng.standard_normal((n_eq, nv))
    A[:6, :6] += 3 * np.eye(6)  # invertible base block
    if seed % 2:  # like a contact's Jacobian: zero on the joints outside its chain
        A[:6, 6:][:, rng.random(nv - 6) < 0.7] = 0.0
    v0 = rng.uniform(-0.3, 0.3, nv)  # a feasible point
    x.A[:] = A
    x.b[:] = A @ v0
    C = rng.standard_normal((n_in, nv))
    x.C[:] = C
    x.l[:] = C @ v0 - rng.uniform(0.0, 0.5, n_in)
    x.u[:] = C @ v0 + rng.uniform(0.0, 0.5, n_in)
    vmax = np.abs(v0[joints]) + rng.uniform(0.2, 2.0, kl)
    q = rng.uniform(-1, 1, nq)
    idx_q = joints + 1
    dt = 0.01
    # position limits that bind (some tighter than the velocity box), v0 inside them
    qmin = q[idx_q] + dt * (v0[joints] - rng.uniform(0.05, 2.0, kl))
    qmax = q[idx_q] + dt * (v0[joints] + rng.uniform(0.05, 2.0, kl))
    lb, ub = np.full(nv, -np.inf), np.full(nv, np.inf)
    lo = np.minimum((qmin - q[idx_q]) / dt, vmax)
    hi = np.maximum((qmax - q[idx_q]) / dt, -vmax)
    lb[joints], ub[joints] = np.minimum(np.maximum(lo, -vmax), vmax), np.maximum(np.minimum(hi, vmax), -vmax)
    x.lb[:], x.ub[:] = lb, ub
    pw = rng.uniform(0.01, 0.1, kl)
    diff, pgain, damping = rng.standard_normal(nv), 10.0, 1e-6
    sfb, sib = rows_pack(mt, nv, joints)
    rows = task_rows.py_func(sfb, sib)
    rows.J[:], rows.e[:], rows.rowp[:], rows.pw[:] = Js, es, rowp, pw
    form_qp(sfb, sib, diff, pgain, damping, x.H, x.g)
    # the same cost in numpy: ½ Σ w (J v − v*)² + ½ Σ d (v_i − s_i)² + ½ ε ‖v‖²
    gain, w, ff = rowp
    target = ff - gain * es
    d = np.zeros(nv)
    d[joints] = pw
    s = -pgain * diff
    H = Js.T @ (w[:, None] * Js) + np.diag(d + damping)
    g = -Js.T @ (w * target) - d * s
    assert np.abs(x.H - H).max() < 1e-12 * max(1.0, np.abs(H).max())
    assert np.abs(x.g - g).max() < 1e-12 * max(1.0, np.abs(g).max())
    assert np.array_equal(x.H, x.H.T)
    before = fb.copy()
    nr = nv - 6 if eliminate else nv
    state, rstate, v = np.zeros(nr, np.int8), np.zeros(n_in, np.int8), np.empty(nv)
    it = kinematic_solve(x, er, dt, 1e-6, 200, state, rstate, ws, iws, v)
    qp_size = ws.ctypes.data - fb.ctypes.data
    assert np.array_equal(fb[:qp_size // 8], before[:qp_size // 8])  # the assembled QP is read, never written
    G, h = np.vstack([C, -C]), np.concatenate([x.u, -x.l])
    ref = qpsolvers.solve_qp(H, g, G=G if n_in else None, h=h if n_in else None, A=A, b=x.b,
                             lb=np.where(np.isfinite(lb), lb, -1e20), ub=np.where(np.isfinite(ub), ub, 1e20),
                             solver="quadprog")
    assert ref is not None
    if it < 1:  # the single-pivot working set gave up (cold start, many active bounds): so does the full-space
        full = make_backend("fast")  # kernel on the same QP, and both controllers' ticks go to DAQP
        full.solve(H, g, A, x.b, C, x.l, x.u, lb, ub)
        assert full.kernel_solves == 0 and full.fallbacks == 1
        return
    assert np.abs(v - ref).max() < 1e-8 * max(1.0, np.abs(ref).max())
    assert np.abs(A @ v - x.b).max() < 1e-7  # the kernel accepts ≤ its tolerance (1e-6 here)
    assert (v >= lb - 1e-9).all() and (v <= ub + 1e-9).all()
    assert np.abs(ws[:nv] - v * dt).max() == 0.0


def test_contact_drift_against_pinocchio():
    """``contact_drift`` returns the largest distance and the largest of max(distance, lever × angle) over the
    contacts (distances and angles from Pinocchio's exp6 and log3; :mod:`wbc.lie`'s gaps: tests/test_lie.py)."""
    import pinocchio as pin

    from wbc.formulations.velocity_kernel import contact_drift

    rng = np.random.default_rng(4)
    logs = rng.normal(size=(2, 6)) * 1e-3
    b = rng.normal(size=12) * 1e-2
    factors = np.array([0.9e-3, -0.1])
    starts = np.array([0, 6])
    dist, ang = [], []
    for i in range(2):
        ea, eb = pin.exp6(logs[i]), pin.exp6(factors[i] * b[6 * i:6 * i + 6])
        dist.append(np.linalg.norm(ea.translation - eb.translation))
        ang.append(np.linalg.norm(pin.log3(ea.rotation.T @ eb.rotation)))
    for lever in (0.0, 0.1, 10.0):
        far, worst = contact_drift(logs, b, starts, factors, lever)
        assert abs(far - max(dist)) <= 1e-15
        assert abs(worst - max(max(d, lever * a) for d, a in zip(dist, ang))) <= 1e-15 * max(1.0, lever)


def test_contact_pair_drift_is_the_two_errors_and_the_drift_in_one_call():
    """``contact_pair_drift`` writes each contact's error log₆(P⁻¹ M) (against Pinocchio's log6) and returns the
    (distance, drift) of ``contact_drift`` on them (the same numbers: one compiled call instead of three), with and
    without the rotation lever, also with an error at a half turn."""
    import pinocchio as pin

    from wbc.formulations.velocity_kernel import contact_drift, contact_pair_drift

    rng = np.random.default_rng(11)
    starts = np.array([3, 11])
    for scale in (1e-6, 0.05, 3.0):
        for _ in range(30):
            places = [pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3)) for _ in range(2)]
            axes = rng.normal(size=(2, 3))
            turns = (axes.T / np.linalg.norm(axes, axis=1) * rng.uniform(0.0, min(scale, 3.0), 2)).T  # < a half turn
            frames = [p * pin.SE3(pin.exp3(w), rng.normal(size=3) * scale) for p, w in zip(places, turns)]
            b, factors = rng.normal(size=17), rng.uniform(-0.01, 0.0, 2)
            args = [(np.vstack([p.rotation, p.translation]), np.asfortranarray(m.rotation), m.translation.copy())
                    for p, m in zip(places, frames)]
            for lever in (0.0, 0.1):
                logs = np.full((2, 6), np.nan)
                d = contact_pair_drift(*args, logs, b, *starts.tolist(), *factors.tolist(), lever)
                for p, m, log in zip(places, frames, logs):
                    ref = pin.log6(p.actInv(m)).vector
                    assert np.abs(log - ref).max() <= 1e-12 * max(1.0, np.abs(ref).max())
                assert d == contact_drift(logs, b, starts, factors, lever)
    p = pin.SE3.Identity()
    half = pin.SE3(pin.exp3(np.array([0.0, 0.0, np.pi])), np.zeros(3))
    ops = (np.vstack([p.rotation, p.translation]), np.asfortranarray(half.rotation), np.zeros(3))
    logs = np.zeros((2, 6))
    far, worst = contact_pair_drift(ops, ops, logs, np.zeros(12), 0, 6, 0.0, 0.0, 0.1)
    assert abs(np.linalg.norm(logs[0, 3:]) - np.pi) <= 1e-12 and far == 0.0 and abs(worst - 0.1 * np.pi) <= 1e-12


def test_contact_pair_drift_is_never_negative_at_and_near_a_half_turn():
    """The compiled tick has no half-turn fallback: ``contact_pair_drift`` (through wbc.lie.placement_log6_into)
    gives Pinocchio's log6 and contact_drift's nonnegative (distance, drift) for errors at, and within 1e-9 rad of,
    a half turn about random axes, with random translations (the drift of Pinocchio's logs recomputed here)."""
    import pinocchio as pin

    from wbc.formulations.velocity_kernel import contact_drift, contact_pair_drift

    rng = np.random.default_rng(12)
    starts, factors = np.array([0, 6]), np.array([-0.002, -0.004])
    for _ in range(200):
        pair = []
        for _ in range(2):
            place = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3))
            axis = rng.normal(size=3)
            angle = np.pi - rng.choice([0.0, 1e-12, 1e-9])
            frame = place * pin.SE3(pin.exp3(axis / np.linalg.norm(axis) * angle), rng.normal(size=3) * 0.01)
            pair.append((place, frame))
        ops = [(np.vstack([p.rotation, p.translation]), np.asfortranarray(m.rotation), m.translation.copy())
               for p, m in pair]
        b = rng.normal(size=12) * 0.01
        logs = np.full((2, 6), np.nan)
        far, worst = contact_pair_drift(*ops, logs, b, 0, 6, *factors.tolist(), 0.1)
        ref = np.array([pin.log6(p.actInv(m)).vector for p, m in pair])
        assert np.allclose(np.linalg.norm(logs[:, 3:], axis=1), np.linalg.norm(ref[:, 3:], axis=1), atol=1e-9)
        assert far >= 0.0 and worst >= 0.0
        far_ref, worst_ref = contact_drift(ref, b, starts, factors, 0.1)
        assert abs(far - far_ref) <= 1e-9 and abs(worst - worst_ref) <= 1e-9


@pytest.mark.parametrize("name", ["talos", "humanoid15"])
def test_sole_drift_is_the_distance_from_where_the_contact_row_sends_the_sole(robots, name):
    """The controller's sole drift of a command v (what its ok-tick bound ``sole_drift_tolerance`` holds) is the
    distance, by forward kinematics, between where the sole ends after one tick and placement · exp((1 − K dt) e),
    where its contact row sends it (before: the gap of the two twists' translation parts, which differs from the
    distance at second order and let a tick of 5.00019e-5 m pass a 5e-5 m bound: kinematic fuzz seed 410013)."""
    import pinocchio as pin

    from conftest import standing_controller
    from wbc.configuration import Configuration

    robot = robots(name)
    config = Configuration(robot)
    ctrl, _ = standing_controller(robot, config)
    rng = np.random.default_rng(7)
    contacts = ctrl.constraints[:2]
    for k, dt in enumerate((0.002, 0.02)):
        offset = pin.SE3(pin.exp3(rng.normal(size=3) * 0.05), rng.normal(size=3) * 1e-3)
        contacts[k % 2].placement = contacts[k % 2].placement * offset  # a sole off its placement
        for _ in range(5):
            v = rng.normal(size=robot.model.nv) * 3.0
            q1 = pin.integrate(robot.model, config.q, v * dt)
            data = robot.model.createData()
            pin.framesForwardKinematics(robot.model, data, q1)
            ref = 0.0
            for c in contacts:
                oMf0 = config.frame_placement(c.frame_id)
                e = pin.log6(c.placement.actInv(oMf0)).vector
                sent = c.placement * pin.exp6(e * (1.0 - min(c.gain, 1.0 / dt) * dt))
                ref = max(ref, np.linalg.norm(data.oMf[c.frame_id].translation - sent.translation))
            assert abs(ctrl.sole_drift(config, v, dt) - ref) <= 1e-12 + 1e-9 * ref


@pytest.mark.parametrize("seed", range(10))
def test_command_screen_passes_only_where_the_unscaled_box_test_does(seed):
    """wbc.formulations.velocity_kernel.command_within (the output guard's compiled screens; no rows here) against the
    numpy test it stands for: v finite, v·v finite and max(lb − v, v − ub) ≤ tolerance; True exactly there (with
    |v| < 1e100), on boxes with infinite sides, NaN entries and commands just inside and just outside by 1e-7
    (tolerance 1e-6)."""
    from wbc.formulations.velocity_kernel import command_within

    rng = np.random.default_rng(900 + seed)
    n, tol = 30, 1e-6
    for _ in range(40):
        lb = -rng.uniform(0.1, 2.0, n)
        ub = rng.uniform(0.1, 2.0, n)
        lb[rng.random(n) < 0.2] = -np.inf
        ub[rng.random(n) < 0.2] = np.inf
        v = rng.uniform(-0.1, 0.1, n)
        k = int(rng.integers(n))
        case = int(rng.integers(6))
        if case == 1 and np.isfinite(ub[k]):
            v[k] = ub[k] + tol - 1e-7  # inside the tolerance
        elif case == 2 and np.isfinite(lb[k]):
            v[k] = lb[k] - tol - 1e-7  # outside it
        elif case == 3:
            v[k] = np.nan
        elif case == 4:
            lb[k] = np.nan
        elif case == 5:
            v[k] = 1e200 if not np.isfinite(ub[k]) else v[k]
        with np.errstate(invalid="ignore", over="ignore"):
            reference = bool(np.isfinite(v @ v) and np.maximum(lb - v, v - ub).max() <= tol)
        screen = command_within(v, lb, ub, np.zeros((0, n)), np.zeros(0), np.zeros(0), tol)
        assert screen == (reference and bool(np.all(np.abs(v) < 1e100)))


@pytest.mark.parametrize("seed", range(10))
def test_row_screen_passes_only_where_the_scaled_row_test_does(seed):
    """wbc.formulations.velocity_kernel.command_within (the output guard's compiled screens; an unbounded box here)
    on inequality rows against the numpy test of the kinematic controller's output guard it stands for, written out
    here: max(l − Cv, Cv − u) / max(1, |C||v|, |l|, |u|) ≤ tolerance (finite bounds in the scale). Whenever the screen
    passes, that test passes; and it passes whenever the test holds with 1e-9 to spare — on rows with infinite sides,
    NaN entries and commands putting one row just inside / just outside its bounds by 1e-7 (tolerance 1e-6)."""
    from wbc.formulations.velocity_kernel import command_within

    rng = np.random.default_rng(950 + seed)
    p, n, tol = 12, 30, 1e-6
    for _ in range(60):
        C = rng.normal(size=(p, n)) * rng.choice([1e-3, 1.0, 50.0], size=(p, 1))
        v = rng.uniform(-0.5, 0.5, n)
        cv = C @ v
        l = cv - rng.uniform(0.0, 2.0, p)
        u = cv + rng.uniform(0.0, 2.0, p)
        l[rng.random(p) < 0.2] = -np.inf
        u[rng.random(p) < 0.2] = np.inf
        k = int(rng.integers(p))
        scale = max(1.0, float(np.abs(C[k]) @ np.abs(v)))
        case = int(rng.integers(6))
        if case == 1:
            u[k] = cv[k] - (tol - 1e-7) * max(scale, abs(cv[k]))  # inside the tolerance
        elif case == 2:
            l[k] = cv[k] + (tol + 1e-7) * max(scale, abs(cv[k]))  # outside it
        elif case == 3:
            v[int(rng.integers(n))] = np.nan
        elif case == 4:
            l[k] = np.nan
        elif case == 5:
            u[k] = cv[k]  # active row
        with np.errstate(invalid="ignore", over="ignore"):
            cv = C @ v
            bound = np.maximum(np.abs(np.where(np.isfinite(l), l, 0.0)), np.abs(np.where(np.isfinite(u), u, 0.0)))
            d = np.maximum(np.maximum(1.0, np.abs(C) @ np.abs(v)), bound)
            over = np.maximum(l - cv, cv - u) / d
            reference = bool(over.max() <= tol)
            spare = bool(over.max() <= tol - 1e-9)
        screen = command_within(v, np.full(n, -np.inf), np.full(n, np.inf), C, l, u, tol)
        assert not screen or reference
        assert screen or not spare


@pytest.mark.parametrize("seed", range(6))
def test_tick_kernel_is_the_cost_the_solve_and_the_screens_in_one_call(seed):
    """kinematic_tick_packed gives bit for bit what form_qp, kinematic_solve and command_within give called one
    after the other (the compiled tick's one call), and refuses a non-finite
    cost or right-hand side before solving."""
    from wbc.formulations.velocity_kernel import (NO_KERNEL_BOX, NONFINITE_RHS, TickBuffers, command_within, form_qp,
                                                  kinematic_pack, kinematic_solve, kinematic_tick_packed,
                                                  kinematic_views, rows_pack, task_rows)

    rng = np.random.default_rng(900 + seed)
    nv, mt, n_eq, n_in = 20, 5, 6, seed % 3
    packs = [(fb, ib, kinematic_views.py_func(fb, ib))
             for fb, ib in (kinematic_pack(nv, n_eq, n_in, 0) for _ in range(2))]
    Js, es = rng.standard_normal((mt, nv)), rng.standard_normal(mt)
    rowp = np.array([rng.uniform(0, 2, mt), rng.uniform(0.1, 10, mt), rng.standard_normal(mt)])
    prow = np.arange(6, nv, dtype=np.int64)
    pw, diff = rng.uniform(0.01, 0.1, prow.size), rng.standard_normal(nv)
    A = rng.standard_normal((n_eq, nv))
    A[:, :6] += 3 * np.eye(6)
    v0 = rng.uniform(-0.3, 0.3, nv)
    C = rng.standard_normal((n_in, nv))
    for fb, ib, (x, *_) in packs:
        x.A[:], x.b[:], x.C[:] = A, A @ v0, C
        x.l[:], x.u[:] = C @ v0 - 0.2, C @ v0 + 0.2
        x.lb[:6], x.ub[:6] = -np.inf, np.inf
        x.lb[6:], x.ub[6:] = -1.0, 1.0
    (_, _, (x1, _, ws1, iws1, _)), (fb2, ib2, (x2, _, ws2, _, _)) = packs
    nr = nv - 6
    s1, r1, v1 = np.zeros(nr, np.int8), np.zeros(n_in, np.int8), np.empty(nv)
    states2, v2 = np.zeros(nr + n_in, np.int8), np.empty(nv)
    s2 = states2[:nr]
    sfb, sib = rows_pack(mt, nv, prow)
    rows = task_rows.py_func(sfb, sib)
    rows.J[:], rows.e[:], rows.rowp[:], rows.pw[:] = Js, es, rowp, pw
    form_qp(sfb, sib, diff, 10.0, 1e-6, x1.H, x1.g)
    it1 = kinematic_solve(x1, 0, 0.002, 1e-6, 200, s1, r1, ws1, iws1, v1)
    guard1 = it1 >= 1 and command_within(v1, x1.lb, x1.ub, C, x1.l, x1.u, 1e-6)
    it2, guard2 = kinematic_tick_packed(TickBuffers(fb2, ib2, sfb, sib, states2), diff, 10.0, 1e-6, v2, 0.002, 1e-6,
                                        200, np.zeros(0), NO_KERNEL_BOX)
    assert it1 >= 1 and (it2, guard2) == (it1, guard1)
    # the QP's buffers and v·dt (the float array's scratch holds each route's own temporaries)
    assert all(np.array_equal(a, b) for a, b in zip(x1, x2)) and np.array_equal(ws1[:nv], ws2[:nv])
    assert np.array_equal(v1, v2) and np.array_equal(s1, s2) and np.array_equal(r1, states2[nr:])
    for bad in ("b", "cost"):
        fb, ib, (x, *_) = packs[1]
        states = states2.copy()
        x.b[0] = np.nan if bad == "b" else A[0] @ v0
        rows.e[:] = es
        if bad == "cost":
            rows.e[0] = np.inf
        code, guard = kinematic_tick_packed(TickBuffers(fb, ib, sfb, sib, states), diff, 10.0, 1e-6, v2, 0.002, 1e-6,
                                            200, np.zeros(0), NO_KERNEL_BOX)
        assert code == NONFINITE_RHS and not guard and np.array_equal(states, states2)


@pytest.mark.parametrize("seed", range(4))
def test_tick_kernel_writes_the_box_from_the_constant_box_and_the_position_limits(seed):
    """kinematic_tick_packed given a constant box and a joint position limit's packed arrays writes lb, ub = the
    constant box clipped by the position bounds lo = min((q_min − q)/dt, v_max), hi = max((q_max − q)/dt, −v_max)
    (numpy formula, each bound clipped into the constant one), before anything else: also when it then
    refuses a non-finite right-hand side; the other entries keep the constant box."""
    from wbc.formulations.velocity_kernel import (NONFINITE_RHS, KernelBox, TickBuffers, kinematic_pack,
                                                  kinematic_tick_packed, kinematic_views, rows_pack, task_rows)

    rng = np.random.default_rng(40 + seed)
    nv, nq, dt = 14, 15, 0.002
    fb, ib = kinematic_pack(nv, 6, 0, 0)
    x = kinematic_views.py_func(fb, ib)[0]
    x.A[:] = rng.standard_normal((6, nv))
    x.A[:, :6] += 3 * np.eye(6)
    sfb, sib = rows_pack(2, nv, np.zeros(0, np.int64))
    rows = task_rows.py_func(sfb, sib)
    rows.J[:], rows.rowp[:] = rng.standard_normal((2, nv)), 1.0
    const = np.array([np.r_[np.full(6, -np.inf), -rng.uniform(0.5, 2, nv - 6)],
                      np.r_[np.full(6, np.inf), rng.uniform(0.5, 2, nv - 6)]])
    idx_v = np.sort(rng.choice(np.arange(6, nv), 5, replace=False))
    idx = np.array([idx_v + 1, idx_v], np.int64)
    q = rng.uniform(-1, 1, nq)
    q_min = q[idx[0]] + rng.uniform(-0.01, 0.003, 5)  # some joints outside their range: the recovery bound
    q_max = q_min + rng.uniform(0.0, 0.01, 5)
    limits = np.array([q_min, q_max, rng.uniform(0.5, 3, 5)])
    lo = np.minimum((q_min - q[idx[0]]) / dt, limits[2])
    hi = np.maximum((q_max - q[idx[0]]) / dt, -limits[2])
    lb, ub = const[0].copy(), const[1].copy()
    lb[idx_v] = np.minimum(np.maximum(lo, const[0, idx_v]), const[1, idx_v])
    ub[idx_v] = np.maximum(np.minimum(hi, const[1, idx_v]), const[0, idx_v])
    for b_value in (0.0, np.nan):
        x.lb[:], x.ub[:], x.b[:] = 9.0, 9.0, b_value
        code, _ = kinematic_tick_packed(TickBuffers(fb, ib, sfb, sib, np.zeros(nv - 6, np.int8)), np.zeros(nv), 0.0,
                                        1e-6, np.empty(nv), dt, 1e-6, 200, q, KernelBox(idx, limits, const))
        assert (code == NONFINITE_RHS) == np.isnan(b_value)
        assert np.array_equal(x.lb, lb) and np.array_equal(x.ub, ub)


def test_compiled_tick_frees_what_numba_allocates():
    """The kinematic bench tick (compiled path; its kernels compiled without numba's reference-counting runtime,
    wbc.compiled.NO_NRT, whose callers do not free arrays returned to them) leaves no numba allocation behind:
    numba's runtime statistics count as many frees as allocations over 200 ticks, and none at all (the tick's
    kernels write into preallocated buffers)."""
    from numba.core.runtime import _nrt_python, rtsys

    from wbc.bench.kinematic import KinematicSpec, WbcRunner
    from wbc.robot import load_robot

    robot = load_robot("talos")
    runner = WbcRunner(KinematicSpec(robot="talos", ticks=260, warmup=20), robot)
    runner.reset()
    for k in range(20):
        runner.tick(k)
    was_enabled = _nrt_python.memsys_stats_enabled()
    _nrt_python.memsys_enable_stats()
    try:
        before = rtsys.get_allocation_stats()
        for k in range(20, 220):
            runner.tick(k)
        after = rtsys.get_allocation_stats()
    finally:
        if not was_enabled:
            _nrt_python.memsys_disable_stats()
    assert runner.failures == 0 and runner.controller.last_result.path.route == "compiled"
    counts = [b - a for a, b in zip(before, after)]  # alloc, free, mi_alloc, mi_free
    assert counts[0] == counts[1] and counts[2] == counts[3]
    assert counts == [0, 0, 0, 0]


def test_walk_tick_frees_what_numba_allocates():
    """The walk tick of wbc.bench.walk (CoM, torso and swing-sole tasks, contacts, ZMP, acceleration and braking
    bounds; its per-tick kernels compiled with wbc.compiled.NO_NRT) makes no numba allocation over a two-step
    walk's ticks (NRT statistics: allocations and frees both zero; main e67e152 made 34.5 per tick)."""
    from numba.core.runtime import _nrt_python, rtsys

    from wbc.bench.walk import walk_ticks
    from wbc.robot import load_robot
    from wbc.scenarios.walk import plan_default_walk

    robot = load_robot("talos")
    ticks = walk_ticks("wbc", robot, plan_default_walk(robot, n_steps=2))
    for _ in range(20):
        next(ticks)
    was_enabled = _nrt_python.memsys_stats_enabled()
    _nrt_python.memsys_enable_stats()
    try:
        before = rtsys.get_allocation_stats()
        n = sum(1 for _ in ticks)
        after = rtsys.get_allocation_stats()
    finally:
        if not was_enabled:
            _nrt_python.memsys_disable_stats()
    assert n > 1000
    assert [b - a for a, b in zip(before, after)] == [0, 0, 0, 0]
