"""Step adjustment (wbc.gait.step_adjustment), replanning with moved footsteps (WalkPlan.replan) and side-stepping
footsteps. References: the DCM ODE ξ̇ = ω(ξ − p) integrated numerically (not the closed form under test), finite
differences of the sampled trajectories, the footstep geometry written here."""

import math

import numpy as np
import pytest

from wbc.exceptions import GaitError
from wbc.gait import Footstep, plan_footsteps, plan_walk
from wbc.gait.step_adjustment import StepAdjuster, StretchLimits

OMEGA = math.sqrt(9.81 / 0.87)


def _adjuster(**kw):
    args = dict(max_forward=0.45, max_backward=0.3, min_width=0.18, max_width=0.5, dead_band=0.0,
                sole_length=0.21, sole_width=0.13)
    args.update(kw)
    return StepAdjuster(OMEGA, **args)


def test_landing_restores_the_nominal_dcm_offset():
    # Plan: stance CoP u0, nominal landing u1, reference DCM xi_ref at time t, tau left. Measured DCM off by e.
    u0, u1 = np.array([0.0, -0.1]), np.array([0.25, 0.1])
    xi_ref, e, tau = np.array([0.12, -0.02]), np.array([0.01, 0.03]), 0.2

    def end_dcm(xi0):  # ξ̇ = ω (ξ − u0), explicit Euler with 1e-5 s steps
        xi = xi0.copy()
        for _ in range(20000):
            xi += 1e-5 * OMEGA * (xi - u0)
        return xi

    b_nom = end_dcm(xi_ref) - u1
    adj = _adjuster()
    d = adj.correction(xi_ref + e, xi_ref, tau)
    new = adj.landing(Footstep("left", *u1, 0.0), (*u0, 0.0), d)
    assert end_dcm(xi_ref + e) - np.array([new.x, new.y]) == pytest.approx(b_nom, abs=2e-4)
    # Eq. 2: landing 0.05 s earlier (tau' = 0.15 s) keeps the nominal offset at the new landing time.
    d2 = adj.correction(xi_ref + e, xi_ref, tau, 0.15, u0)
    xi = xi_ref + e
    for _ in range(15000):
        xi = xi + 1e-5 * OMEGA * (xi - u0)
    assert xi - (u1 + d2) == pytest.approx(b_nom, abs=2e-4)


def test_dead_band_reach_and_collision_limits():
    adj = _adjuster(dead_band=0.03)
    assert not adj.correction([0.02, 0.0], [0.0, 0.0], 0.3).any()
    d = adj.correction([0.05, 0.0], [0.0, 0.0], 0.3)
    assert d == pytest.approx([math.exp(OMEGA * 0.3) * 0.02, 0.0])
    stance = (1.0, -0.1, 0.0)
    nominal = Footstep("left", 1.2, 0.1, 0.0)
    far = adj.landing(nominal, stance, np.array([1.0, 1.0]))  # beyond the reach: clipped to the box corner
    assert (far.x, far.y) == pytest.approx((1.45, 0.4))
    inward = adj.landing(nominal, stance, np.array([0.0, -0.5]))  # towards the stance leg: held at min width
    assert inward.y == pytest.approx(-0.1 + 0.18)
    back = adj.landing(nominal, stance, np.array([-1.0, 0.0]))
    assert back.x == pytest.approx(0.7)
    assert far.side == "left" and far.yaw == 0.0
    right = adj.landing(Footstep("right", 1.2, -0.3, 0.0), (1.0, -0.1, 0.0), np.array([0.0, 0.6]))
    assert right.y == pytest.approx(-0.1 - 0.18)  # a right foot stays on the right of the left stance foot
    with pytest.raises(GaitError):
        StepAdjuster(OMEGA, max_forward=0.4, max_backward=0.3, min_width=0.3, max_width=0.2)


def _plan():
    L, R = np.eye(4), np.eye(4)
    L[1, 3], R[1, 3] = 0.1, -0.1
    return plan_walk(L, R, np.array([0.0, 0.0, 0.87]), n_steps=6, step_length=0.2, t_ss=0.5, t_ds=0.1,
                     t_init=0.6, t_final=0.8)


def test_stretch_samples_lengthen_a_late_swing_until_the_landing_is_in_reach():
    """The lengthening returned makes the landing of eq. 2 reachable at the foot's speed (checked here with the
    adjuster's own correction and landing, and that one 10 ms step less would not); none when the foot is close
    enough or the landing barely moved."""
    adj = _adjuster()
    limits = StretchLimits(max_stretch=0.15, stretch_speed=1.0, stretch_min=0.02, dt=0.002)
    stance, nominal = (0.0, 0.0, 0.0), Footstep("left", 0.25, 0.2, 0.0)
    xi_ref = np.array([0.1, 0.02])
    xi = xi_ref + np.array([0.0, 0.06])  # pushed towards the swing side
    tau = 0.05
    corr = adj.correction(xi, xi_ref, tau)
    target = adj.landing(nominal, stance, corr)
    far = (0.25, 0.05)  # no lengthening up to 0.15 s brings the landing within reach: the longest
    assert adj.stretch_samples(limits, nominal, nominal, stance, corr, target, far, (xi, xi_ref), tau) == 75
    foot = (0.25, 0.18)  # 9 cm from the landing, more than 1 m/s × 0.05 s
    n = adj.stretch_samples(limits, nominal, nominal, stance, corr, target, foot, (xi, xi_ref), tau)
    assert 0 < n < 75

    def reachable(m):
        tl = tau + m * limits.dt
        t2 = adj.landing(nominal, stance, adj.correction(xi, xi_ref, tau, tl, np.array(stance[:2])))
        return math.hypot(t2.x - foot[0], t2.y - foot[1]) <= limits.stretch_speed * tl

    assert reachable(n) and not reachable(n - 5)
    near = (target.x, target.y - 0.01)
    assert adj.stretch_samples(limits, nominal, nominal, stance, corr, target, near, (xi, xi_ref), tau) == 0
    assert adj.stretch_samples(limits, nominal, target, stance, corr, target, foot, (xi, xi_ref), tau) == 0


def test_replan_with_moved_footsteps():
    p = _plan()
    ph = next(x for x in p.phases if x.step == 1)  # the second swing
    k = ph.first + ph.count // 2
    old = p.footsteps[1:]
    d = np.array([0.03, -0.12])
    new = [Footstep(f.side, f.x + d[0], f.y + d[1], f.yaw) for f in old]
    com, com_vel = p.com[k] + [0.01, -0.02, 0.0], p.com_vel[k] + [0.0, -0.2, 0.0]
    q = p.replan(k, com, com_vel, new, check_start=False)
    side = old[0].side
    P, V = (q.left_sole, q.left_sole_vel) if side == "left" else (q.right_sole, q.right_sole_vel)
    P0, V0 = (p.left_sole, p.left_sole_vel) if side == "left" else (p.right_sole, p.right_sole_vel)
    # Continuous at the replanning sample; lands on the moved footstep at the planned touch-down sample.
    assert np.abs(P[0] - P0[k]).max() == 0.0 and np.abs(V[0] - V0[k]).max() == 0.0
    assert P[ph.end - k][:2, 3] == pytest.approx([new[0].x, new[0].y], abs=1e-12)
    assert P[ph.end - k][2, 3] == pytest.approx(0.0, abs=1e-12)
    # Velocities are the derivatives of the poses (central differences).
    for Pf, Vf in ((q.left_sole, q.left_sole_vel), (q.right_sole, q.right_sole_vel)):
        fd = (Pf[2:, :3, 3] - Pf[:-2, :3, 3]) / (2 * q.dt)
        assert np.abs(fd - Vf[1:-1, :3]).max() < 2e-3
    # Final feet moved by d; the DCM starts at the measured c + ċ/ω; the CoM is a LIPM of the ZMP.
    for Pf, Pf0 in ((q.left_sole, p.left_sole), (q.right_sole, p.right_sole)):
        assert Pf[-1][:2, 3] - Pf0[-1][:2, 3] == pytest.approx(d, abs=1e-12)
    assert q.dcm[0] == pytest.approx(com[:2] + com_vel[:2] / q.omega, abs=1e-9)
    acc = (q.com[2:, :2] - 2 * q.com[1:-1, :2] + q.com[:-2, :2]) / q.dt**2
    lipm = q.omega**2 * (q.com[1:-1, :2] - q.zmp[1:-1])
    kink = np.zeros(len(acc), bool)  # the ZMP slope changes at segment starts: central differences see c⃛ jump
    for f in q.segments.first[1:]:
        kink[max(f - 2, 0):f + 1] = True
    err = np.abs(acc - lipm).max(axis=1)
    assert err[~kink].max() < 1e-4 and err.max() < 0.05
    assert q.zmp[-1] == pytest.approx(0.5 * (q.left_sole[-1][:2, 3] + q.right_sole[-1][:2, 3]), abs=1e-9)
    # The stance foot does not move before its own lift-off.
    other = q.right_sole if side == "left" else q.left_sole
    assert np.abs(other[: ph.end - k + 1] - other[0]).max() == 0.0
    # Only x, y may change; the count must match; the check of the ZMP start raises when asked.
    with pytest.raises(GaitError, match="only x, y"):
        p.replan(k, com, com_vel, [Footstep(f.side, f.x, f.y, f.yaw + 0.1) for f in old])
    with pytest.raises(GaitError, match="remaining steps"):
        p.replan(k, com, com_vel, new[1:])
    with pytest.raises(GaitError, match="outside the current support polygon"):
        p.replan(k, p.com[k], p.com_vel[k] + [0.0, -1.0, 0.0], new)


@pytest.mark.parametrize("ramp, peak", [(None, 1.875), (0.3, 1 / 0.7), (0.5, 2.0)])
def test_replan_swing_ramp_sets_the_top_speed_of_the_moved_swing(ramp, peak):
    """The swing in progress follows a moved landing by d over its n remaining samples of dt: its velocity changes by
    b'(s) d / (n dt), whose peak is 1.875 |d| / (n dt) for the minimum-jerk blend and |d| / ((1 − r) n dt) for the
    ramped trapezoid (closed forms of wbc.profiles' docstring); the poses' central differences are the velocities."""
    p = _plan()
    ph = next(x for x in p.phases if x.step == 1)
    n = 2 * (ph.count // 4)  # (even: the blend's sample s = ½ is the minimum-jerk peak)
    k = ph.end - n
    d = np.array([0.02, 0.15])
    new = [Footstep(f.side, f.x + d[0], f.y + d[1], f.yaw) for f in p.footsteps[1:]]
    q = p.replan(k, p.com[k], p.com_vel[k], new, check_start=False, swing_ramp=ramp)
    side = p.footsteps[1].side
    P, V = (q.left_sole, q.left_sole_vel) if side == "left" else (q.right_sole, q.right_sole_vel)
    P0, V0 = (p.left_sole, p.left_sole_vel) if side == "left" else (p.right_sole, p.right_sole_vel)
    added = np.linalg.norm(V[:n, :2] - V0[k:k + n, :2], axis=1)
    assert added.max() == pytest.approx(peak * np.linalg.norm(d) / (n * q.dt), rel=1e-9)
    assert np.abs(P[0] - P0[k]).max() == 0.0 and np.abs(V[0] - V0[k]).max() == 0.0
    assert P[n][:2, 3] == pytest.approx([new[0].x, new[0].y], abs=1e-12)
    fd = (P[2:n, :2, 3] - P[:n - 2, :2, 3]) / (2 * q.dt)
    assert np.abs(fd - V[1:n - 1, :2]).max() < 2e-3
    # the next swing (the other foot, from its unmoved rest to a landing moved by d) keeps the minimum-jerk blend
    later = next(x for x in p.phases if x.step == 2)
    m = later.count
    V2, V20 = (q.left_sole_vel, p.left_sole_vel) if p.footsteps[2].side == "left" else (q.right_sole_vel,
                                                                                         p.right_sole_vel)
    s = np.arange(m) / m
    mj = 30 * s**2 - 60 * s**3 + 30 * s**4  # b'(s) of the minimum-jerk blend (Flash & Hogan 1985)
    want = np.outer(mj / (m * q.dt), d)
    assert np.abs(V2[later.first - k:later.first - k + m, :2] - V20[later.first:later.first + m, :2] - want).max() \
        < 1e-12
    for bad in (0.0, 0.6, True, "0.3", float("nan")):
        with pytest.raises(GaitError, match="swing_ramp"):
            p.replan(k, p.com[k], p.com_vel[k], new, check_start=False, swing_ramp=bad)


def test_side_step_footsteps():
    w, d = 0.2, 0.05
    steps = plan_footsteps((0.0, w / 2, 0.0), (0.0, -w / 2, 0.0), 9, 0.0, w, 0.0, "left", d)
    feet = {"left": (0.0, w / 2), "right": (0.0, -w / 2)}
    mids = [0.0]
    for fs in steps:
        feet[fs.side] = (fs.x, fs.y)
        gap = feet["left"][1] - feet["right"][1]
        assert gap >= w - 1e-12  # the legs never come closer than the step width
        mids.append(0.5 * (feet["left"][1] + feet["right"][1]))
    assert np.diff(mids)[:-1] == pytest.approx([d] * 8)  # every walking step moves the mid-point by d
    assert mids[-1] == pytest.approx(8 * d) and feet["left"][1] - feet["right"][1] == pytest.approx(w)
    right = plan_footsteps((0.0, w / 2, 0.0), (0.0, -w / 2, 0.0), 9, 0.0, w, 0.0, "right", -d)
    assert right[0].side == "right" and right[0].y == pytest.approx(-w / 2 - 2 * d)


def test_replan_skip_ends_the_swing_earlier():
    p = _plan()
    ph = next(x for x in p.phases if x.step == 1)
    k = ph.first + ph.count // 2
    n_left = ph.end - k
    q = p.replan(k, p.com[k], p.com_vel[k], skip=50, check_start=False)
    assert q.n_samples == p.n_samples - k - 50
    side = p.footsteps[1].side
    P = q.left_sole if side == "left" else q.right_sole
    P0 = p.left_sole if side == "left" else p.right_sole
    # The swing lands 50 samples earlier on the same footstep; the rest of the plan is the old one, 50 samples earlier.
    assert q.support[n_left - 50 - 1] != 0 and q.support[n_left - 50] == 0
    assert P[n_left - 50][:3, 3] == pytest.approx(P0[ph.end][:3, 3], abs=1e-12)
    assert np.array_equal(P[n_left - 50:], P0[ph.end:])
    assert P[0][:3, 3] == pytest.approx(P0[k][:3, 3], abs=1e-12)
    assert q.dcm[0] == pytest.approx(p.com[k, :2] + p.com_vel[k, :2] / p.omega, abs=1e-9)
    with pytest.raises(GaitError, match="skip"):
        p.replan(k, p.com[k], p.com_vel[k], skip=n_left, check_start=False)


def test_replan_negative_skip_lengthens_the_swing():
    p = _plan()
    ph = next(x for x in p.phases if x.step == 1)
    k = ph.first + ph.count // 2
    n_left = ph.end - k
    q = p.replan(k, p.com[k], p.com_vel[k], skip=-40, check_start=False)
    assert q.n_samples == p.n_samples - k + 40
    side = p.footsteps[1].side
    P, P0 = (q.left_sole, p.left_sole) if side == "left" else (q.right_sole, p.right_sole)
    S, S0 = (q.right_sole, p.right_sole) if side == "left" else (q.left_sole, p.left_sole)  # stance foot
    # The swing lands 40 samples later on the same footstep; the rest of the plan is the old one, 40 samples later.
    assert q.support[n_left + 40 - 1] != 0 and q.support[n_left + 40] == 0
    assert P[n_left + 40][:3, 3] == pytest.approx(P0[ph.end][:3, 3], abs=1e-12)
    assert np.array_equal(P[n_left + 40:], P0[ph.end:])
    assert P[0][:3, 3] == pytest.approx(P0[k][:3, 3], abs=1e-12)
    # The stretched swing stays continuous (no step > the old largest step per sample) and the stance foot is held.
    step = np.linalg.norm(np.diff(P[:n_left + 41, :3, 3], axis=0), axis=1).max()
    assert step <= np.linalg.norm(np.diff(P0[k:ph.end + 1, :3, 3], axis=0), axis=1).max() + 1e-12
    assert np.all(S[:n_left + 40, :3, 3] == S0[k, :3, 3])
    with pytest.raises(GaitError, match="skip"):
        p.replan(k, p.com[k], p.com_vel[k], skip=-10_000, check_start=False)


def test_kinematic_walk_velocity_commands(tmp_path):
    # `wbc walk --vy`: side-steps of vy x (t_ss + t_ds) (Talos gait: 0.8 + 0.3 s); `--vx --wz`: an arc.
    from wbc.cli import main

    log = tmp_path / "side.npz"
    assert main(["walk", "--steps", "5", "--vy", "0.05", "--quiet", "--log", str(log)]) == 0
    d = np.load(log)
    mid = 0.5 * (d["left_sole"][:, :2, 3] + d["right_sole"][:, :2, 3])
    # 4 walking steps of 0.055 m to the left (the closing step is the leading foot's: no displacement)
    assert mid[-1] - mid[0] == pytest.approx([0.0, 4 * 0.05 * 1.1], abs=2e-3)
    log2 = tmp_path / "arc.npz"
    assert main(["walk", "--steps", "4", "--vx", "0.1", "--wz", "5", "--quiet", "--log", str(log2)]) == 0
    d = np.load(log2)
    R = d["left_sole"][-1, :3, :3]
    assert math.atan2(R[1, 0], R[0, 0]) == pytest.approx(math.radians(3 * 5 * 1.1), abs=math.radians(0.5))
