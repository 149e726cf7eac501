"""Capturability in the LIPM (wbc.analysis.capturability) against closed forms written here and an independent
numerical integration of c̈ = ω²(c − p) + F/m with the optimal CoP and step of a push along a sole axis."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wbc.analysis.capturability import CaptureModel, capturability, capture_margins, push_capture_shift
from wbc.exceptions import InvalidInputError

G = 9.81
OMEGA = 3.0  # 1/s: z0 = g / 9
MASS = 90.0  # kg
SOLE = (0.20, 0.10)  # m, length x width
STEP = 0.5  # m, ℓ_max
STEP_TIME = 0.6  # s
SWING = 0.48  # s


@pytest.fixture
def model():
    return CaptureModel(mass=MASS, com_height=G / OMEGA**2, sole_length=SOLE[0], sole_width=SOLE[1], step_max=STEP,
                        step_time=STEP_TIME, swing_time=SWING, gravity=G)


def test_omega_is_the_lipm_frequency(model):
    assert model.omega == pytest.approx(3.0, abs=1e-12)


def test_zero_step_capture_point_inside_the_sole(model):
    # at rest, CoM over (0.09, 0.04): capture point inside the 0.2 x 0.1 sole at the origin
    r = capturability(model, [0.09, 0.04], [0.0, 0.0], [0.0, 0.0], 0.1, [(0.0, 0.0, 0.0)], 0.3)
    assert r.steps == 0 and r.distance == 0.0
    # capture point 1 mm past the front edge: not 0-step, 1-step (margin e^{-0.9}·0.5 = 0.203 m)
    r = capturability(model, [0.0, 0.0], [0.101 * OMEGA, 0.0], [0.0, 0.0], 0.1, [(0.0, 0.0, 0.0)], 0.3)
    assert r.steps == 1 and r.distance == pytest.approx(0.001, abs=1e-12)


def test_zero_step_with_a_yawed_sole(model):
    # sole turned 90°: its length along world y; a capture point 0.09 m along y is inside, 0.09 along x is not
    assert capturability(model, [0, 0.09], [0, 0], [0, 0], 0, [(0, 0, math.pi / 2)], 0.3).steps == 0
    assert capturability(model, [0.09, 0], [0, 0], [0, 0], 0, [(0, 0, math.pi / 2)], 0.3).steps == 1


def test_double_support_hull_holds_without_a_step(model):
    soles = [(0.0, 0.1, 0.0), (0.0, -0.1, 0.0)]
    r = capturability(model, [0.05, 0.0], [0, 0], [0, 0], 0, soles, SWING)  # between the soles, in neither
    assert r.steps == 0 and r.distance == pytest.approx(0.05, abs=1e-12)


def test_margins_against_the_hand_computed_recursion(model):
    # β'_1 = ℓ e^{-ω t1}; β'_2 = (ℓ + ℓ e^{-ω Δt}) e^{-ω t1}; t1 = 0.4 s, ω = 3, Δt = 0.6 s
    e1, e2 = 0.30119421191220214, 0.16529888822158653  # e^{-1.2}, e^{-1.8}
    m = capture_margins(model, 0.4, 3)
    assert m[0] == 0.0
    assert m[1] == pytest.approx(0.5 * e1, rel=1e-12)
    assert m[2] == pytest.approx((0.5 + 0.5 * e2) * e1, rel=1e-12)
    assert m[3] == pytest.approx((0.5 + 0.5 * e2 + 0.5 * e2 * e2) * e1, rel=1e-12)


def test_disc_foot_matches_the_papers_finite_foot_recursion():
    # Koolen et al. 2012 with a disc foot of radius r: d_N = (ℓ - r + d_{N-1}) e^{-ωΔt} + r, d_0 = r; the
    # rectangle's region S ⊕ β_N B along a sole axis reaches r + β_N (r the half-length)
    r, ell, dt = 0.1, 0.5, 0.6
    m = CaptureModel(mass=MASS, com_height=G / 9.0, sole_length=2 * r, sole_width=2 * r, step_max=ell,
                     step_time=dt, swing_time=0.5, gravity=G)
    d = [r]
    for _ in range(3):
        d.append((ell - r + d[-1]) * math.exp(-3.0 * dt) + r)
    assert np.allclose(r + capture_margins(m, dt, 3), d, atol=1e-12)


def _lipm(c0, v0, force, duration, t_end, cop, dt=1e-4):
    """RK4 of c̈ = ω²(c − p) + F/m (1-D), p = cop(t, c, ċ), F on over the steps that start before ``duration``
    (a multiple of dt); returns the (t, c, ċ) samples."""
    def f(t, y, push):
        p = cop(t, y[0], y[1])
        return np.array([y[1], OMEGA**2 * (y[0] - p) + push])

    y, t, out = np.array([c0, v0], dtype=float), 0.0, []
    n = int(round(t_end / dt))
    for i in range(n):
        a = force / MASS if i < round(duration / dt) else 0.0
        k1 = f(t, y, a)
        k2 = f(t + dt / 2, y + dt / 2 * k1, a)
        k3 = f(t + dt / 2, y + dt / 2 * k2, a)
        k4 = f(t + dt, y + dt * k3, a)
        y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        t = (i + 1) * dt
        out.append((t, y[0], y[1]))
    return np.array(out)


def test_push_acts_as_the_capture_point_jump(model):
    # CoP held at 0.03 m; push 400 N for 0.1 s: for t >= T, ξ(t) = p + e^{ωt}(ξ0 + Δξ - p)
    c0, v0, p = 0.01, 0.05, 0.03
    run = _lipm(c0, v0, 400.0, 0.1, 0.5, lambda t, c, v: p)
    jump = push_capture_shift(model, [400.0, 0.0, 0.0], 0.1)[0]
    for t, c, v in run[run[:, 0] >= 0.1][::500]:
        assert c + v / OMEGA == pytest.approx(p + math.exp(OMEGA * t) * (c0 + v0 / OMEGA + jump - p), abs=1e-9)


def _captured_by_one_step(force, t1, half):
    """Optimal 1-D recovery (push along +x from rest over the sole's centre): CoP at the front edge until the
    touch-down at t1, the new sole ℓ_max ahead, then the CoP at the point of the new sole nearest the capture point.
    Captured: 2 s after the touch-down the capture point is on the new sole and the CoM nearly at rest (not
    captured: it runs away, at metres per second)."""
    def cop(t, c, v):
        if t < t1:
            return half
        xi = c + v / OMEGA
        return min(max(xi, STEP - half), STEP + half)

    run = _lipm(0.0, 0.0, force, 0.1, t1 + 2.0, cop)
    c, v = run[-1, 1], run[-1, 2]
    return abs(v) < 0.01 and abs(c + v / OMEGA - STEP) <= half


@pytest.mark.parametrize("axis, half", [(0, SOLE[0] / 2), (1, SOLE[1] / 2)])
def test_one_step_boundary_against_the_integrated_lipm(model, axis, half):
    t1 = 0.3
    u = np.eye(2)[axis]

    def steps(f):
        return capturability(model, [0, 0], [0, 0], f * u, 0.1, [(0.0, 0.0, 0.0)], t1, n_max=1).steps

    lo, hi = 0.0, 5000.0  # the classifier's 1-step boundary force, by bisection
    assert steps(lo) == 0 and steps(hi) is None
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if steps(mid) is not None else (lo, mid)
    assert _captured_by_one_step(0.98 * lo, t1, half)
    assert not _captured_by_one_step(1.02 * lo, t1, half)


def test_steps_grow_with_the_force(model):
    stance = [(0.0, -0.1, 0.0)]
    for direction in np.radians([0, 45, 100, 200, 290]):
        u = np.array([math.cos(direction), math.sin(direction)])
        seen = [capturability(model, [0.02, -0.08], [0.1, 0.05], f * u, 0.1, stance, 0.25, n_max=4).steps
                for f in np.linspace(0.0, 3000.0, 61)]
        as_num = [math.inf if s is None else s for s in seen]
        assert as_num == sorted(as_num)
        assert as_num[0] == 0 and as_num[-1] == math.inf


def test_of_robot_reads_the_robot(robots):
    talos = robots("talos")
    import pinocchio as pin

    from wbc.analysis.legs import leg_reach

    m = CaptureModel.of_robot(talos, 0.6, 0.48)
    data = talos.model.createData()
    assert m.mass == pytest.approx(pin.computeTotalMass(talos.model), rel=1e-12)
    com = pin.centerOfMass(talos.model, data, talos.q_ref)
    pin.framesForwardKinematics(talos.model, data, talos.q_ref)
    assert m.com_height == pytest.approx(com[2] - data.oMf[talos.frame_id(talos.left_sole)].translation[2], abs=1e-9)
    assert m.step_max == leg_reach(talos) and m.sole_length == talos.sole_length


@pytest.mark.parametrize("kwargs, what", [
    ({"force": [float("nan"), 0.0]}, "force"), ({"duration": -0.1}, "push duration"),
    ({"stance": [(0, 0, 0)] * 3}, "stance"), ({"t_first": -1.0}, "t_first"), ({"n_max": -1}, "n_max"),
    ({"com": [0.0]}, "com")])
def test_bad_input_is_named(model, kwargs, what):
    args = {"com": [0, 0], "com_velocity": [0, 0], "force": [100, 0], "duration": 0.1, "stance": [(0, 0, 0)],
            "t_first": 0.3, **kwargs}
    with pytest.raises(InvalidInputError, match=what):
        capturability(model, **args)


def test_model_refuses_a_swing_longer_than_the_step():
    with pytest.raises(InvalidInputError, match="swing_time"):
        CaptureModel(mass=MASS, com_height=1.0, sole_length=0.2, sole_width=0.1, step_max=0.5, step_time=0.4,
                     swing_time=0.5)
