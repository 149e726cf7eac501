"""Step location and timing QP (wbc.gait.step_timing). References: the same QP written out here and solved by
quadprog and ProxQP through qpsolvers (not DAQP, which the module uses); the DCM ODE ξ̇ = ω(ξ − u_0) integrated
numerically (not the closed form the QP's equality is built from); the reach box written in the stance frame."""

import math

import numpy as np
import pytest
import qpsolvers

from wbc.exceptions import GaitError
from wbc.gait.step_timing import STEP_TIMING_WEIGHTS, StepTimingQP

OMEGA = math.sqrt(9.81 / 0.877)
REACH = dict(max_forward=0.57, max_backward=0.31, min_width=0.18, max_width=0.79)


def _qp(**kw):
    return StepTimingQP(OMEGA, **{**REACH, **kw})


def _reference(xi, stance, u0, left, t, un, tn, bn, tmin, tmax, solver):
    """(K1)-(K4) written with the reach as four one-sided rows, solved by ``solver`` through qpsolvers."""
    au, at, ab = STEP_TIMING_WEIGHTS
    P = 2.0 * np.diag([au, au, at, ab, ab])
    q = -2.0 * np.array([au * un[0], au * un[1], at * math.exp(OMEGA * tn), ab * bn[0], ab * bn[1]])
    g = (np.asarray(xi) - u0) * math.exp(-OMEGA * t)
    A = np.array([[1.0, 0.0, -g[0], 1.0, 0.0], [0.0, 1.0, -g[1], 0.0, 1.0]])
    c, s = math.cos(stance[2]), math.sin(stance[2])
    sg = 1.0 if left else -1.0
    fwd, lat = np.array([c, s]), sg * np.array([-s, c])
    p = np.array(stance[:2])
    G = np.zeros((4, 5))
    G[0, :2], G[1, :2], G[2, :2], G[3, :2] = fwd, -fwd, lat, -lat
    h = np.array([fwd @ p + REACH["max_forward"], -(fwd @ p) + REACH["max_backward"],
                  lat @ p + REACH["max_width"], -(lat @ p) - REACH["min_width"]])
    lb = np.array([-1e6, -1e6, math.exp(OMEGA * tmin), -1e6, -1e6])
    ub = np.array([1e6, 1e6, math.exp(OMEGA * tmax), 1e6, 1e6])
    tight = {"eps_abs": 1e-10, "eps_rel": 0.0} if solver == "proxqp" else {}
    return qpsolvers.solve_qp(P, q, G, h, A, np.asarray(u0, float), lb, ub, solver=solver, **tight)


def _case(rng):
    yaw = rng.uniform(-0.6, 0.6)
    left = bool(rng.integers(2))
    stance = (rng.uniform(-1, 1), rng.uniform(-1, 1), yaw)
    u0 = np.array(stance[:2]) + rng.uniform(-0.03, 0.03, 2)
    sg = 1.0 if left else -1.0
    un = np.array(stance[:2]) + 0.25 * np.array([math.cos(yaw), math.sin(yaw)]) \
        + sg * 0.2 * np.array([-math.sin(yaw), math.cos(yaw)])
    t = rng.uniform(0.0, 0.4)
    tn = 0.48
    xi_ref = u0 + 0.5 * (un - u0) * math.exp(-OMEGA * (tn - t))  # the plan's DCM heading for the landing
    xi = xi_ref + rng.uniform(-0.12, 0.12, 2)
    bn = np.array([0.02, -sg * 0.06])
    tmin = t + rng.uniform(0.05, 0.15)
    return dict(xi=xi, stance=stance, u0=u0, left=left, t=t, un=un, tn=tn, bn=bn, tmin=tmin, tmax=tmin + 0.3)


def _solve(qp, c):
    return qp.solve(c["xi"], stance=c["stance"], stance_cop=c["u0"], swing_left=c["left"], elapsed=c["t"],
                    landing_nom=c["un"], duration_nom=c["tn"], offset_nom=c["bn"], t_min=c["tmin"], t_max=c["tmax"])


@pytest.mark.parametrize("solver", ["quadprog", "proxqp"])
def test_solution_equals_an_independent_solver(solver):
    rng = np.random.default_rng(61)
    qp = _qp()
    active = 0
    for _ in range(200):
        c = _case(rng)
        r = _solve(qp, c)
        ref = _reference(c["xi"], c["stance"], c["u0"], c["left"], c["t"], c["un"], c["tn"], c["bn"], c["tmin"],
                         c["tmax"], solver)
        x = np.concatenate([r.landing, [r.tau], r.offset])
        assert x == pytest.approx(ref, abs=2e-6, rel=1e-6)
        assert r.duration == pytest.approx(math.log(ref[2]) / OMEGA, abs=1e-6)
        active += not (c["tmin"] + 1e-6 < r.duration < c["tmax"] - 1e-6)
    assert active > 20  # (the draws reach the timing bounds, not only the interior)


def test_the_landing_and_time_capture_the_dcm_of_the_lipm():
    """ξ̇ = ω(ξ − u_0) integrated (explicit Euler, 1e-5 s) from the measured DCM to the QP's touch-down time ends
    at the QP's landing plus its offset; a DCM on the plan gives the plan's step back."""
    rng = np.random.default_rng(3)
    qp = _qp()
    for _ in range(5):
        c = _case(rng)
        r = _solve(qp, c)
        xi = c["xi"].copy()
        n = int(round((r.duration - c["t"]) / 1e-5))
        for _ in range(n):
            xi += 1e-5 * OMEGA * (xi - c["u0"])
        rest = r.duration - c["t"] - n * 1e-5  # (the last fraction of a step)
        xi += rest * OMEGA * (xi - c["u0"])
        assert xi - r.landing == pytest.approx(r.offset, abs=3e-4)
    # On the plan: ξ = ξ_ref, b_nom the plan's own offset, the nominal step inside the bounds.
    c = _case(np.random.default_rng(5))
    tl = c["tn"] - c["t"]
    xi_ref = c["xi"]
    bn = qp.nominal_offset(xi_ref, c["u0"], c["un"], tl)
    c.update(bn=bn, tmin=c["t"] + 0.01, tmax=c["tn"] + 0.2)
    r = _solve(qp, c)
    assert r.landing == pytest.approx(c["un"], abs=1e-9)
    assert r.duration == pytest.approx(c["tn"], abs=1e-9)
    assert r.offset == pytest.approx(bn, abs=1e-9)


def test_bounds_and_the_cut_of_a_step_the_reach_stops():
    """A DCM pushed towards the stance leg asks for a landing inside min_width: the landing stops there and the
    step lands sooner (T < T_nom); pushed outwards beyond max_width the landing stops at max_width, also sooner
    (the DCM diverges less). Every landing in the stance-frame box, every T in its bounds."""
    qp = _qp()
    stance, u0 = (0.0, -0.1, 0.0), np.array([0.0, -0.1])
    un, tn, t = np.array([0.25, 0.1]), 0.48, 0.15
    xi_ref = u0 + 0.5 * (un - u0) * math.exp(-OMEGA * (tn - t))
    bn = qp.nominal_offset(xi_ref, u0, un, tn - t)
    kw = dict(stance=stance, stance_cop=u0, swing_left=True, elapsed=t, landing_nom=un, duration_nom=tn,
              offset_nom=bn, t_min=0.25, t_max=0.6)
    inward = qp.solve(xi_ref + [0.0, -0.08], **kw)
    assert inward.landing[1] == pytest.approx(-0.1 + 0.18, abs=1e-9)
    assert 0.25 - 1e-9 <= inward.duration < tn - 0.02
    outward = qp.solve(xi_ref + [0.0, 0.3], **kw)
    assert outward.landing[1] == pytest.approx(-0.1 + 0.79, abs=1e-9)
    assert outward.duration < tn - 0.02
    small = qp.solve(xi_ref + [0.02, 0.02], **kw)  # inside the reach: the landing moves, the time barely
    assert abs(small.duration - tn) < 0.005
    assert small.landing - un == pytest.approx(0.02 * math.exp(OMEGA * (tn - t)), rel=0.02)
    rng = np.random.default_rng(7)
    for _ in range(100):
        c = _case(rng)
        r = _solve(qp, c)
        yaw = c["stance"][2]
        d = r.landing - np.array(c["stance"][:2])
        fx = math.cos(yaw) * d[0] + math.sin(yaw) * d[1]
        fy = (1.0 if c["left"] else -1.0) * (-math.sin(yaw) * d[0] + math.cos(yaw) * d[1])
        assert -REACH["max_backward"] - 1e-7 <= fx <= REACH["max_forward"] + 1e-7
        assert REACH["min_width"] - 1e-7 <= fy <= REACH["max_width"] + 1e-7
        assert c["tmin"] - 1e-9 <= r.duration <= c["tmax"] + 1e-9


def test_typed_errors_on_bad_input():
    with pytest.raises(GaitError):
        StepTimingQP(0.0, **REACH)
    with pytest.raises(GaitError):
        StepTimingQP(OMEGA, **{**REACH, "min_width": 0.9})
    with pytest.raises(GaitError):
        StepTimingQP(OMEGA, **REACH, weights=(1.0, -1.0, 1.0))
    with pytest.raises(GaitError):
        StepTimingQP(OMEGA, **{**REACH, "max_forward": math.nan})
    qp = _qp()
    c = _case(np.random.default_rng(1))
    with pytest.raises(GaitError, match="xi"):
        _solve(qp, {**c, "xi": np.array([math.nan, 0.0])})
    with pytest.raises(GaitError, match="elapsed"):
        _solve(qp, {**c, "tmin": c["t"] - 0.1})
    with pytest.raises(GaitError, match="finite"):
        _solve(qp, {**c, "tmax": math.inf})
