""":mod:`wbc.gait.blind`: the blind swing and the partial-foothold band, without a simulator. The swing is checked
against its own definition (foothold reached at 80 % of the swing, lift held between 30 % and 60 %) and its
velocities against finite differences of its positions; the band against cases worked by hand (numbers written
here); the band of a sole rotating about one of its edges against MuJoCo's contacts."""

import math

import mujoco
import numpy as np
import pinocchio as pin

from conftest import box_sole_mjcf
from wbc.gait.blind import BLIND_ROLL_RATE, blind_swing_into, clip_band_range, roll_band

DT = 0.002
H = 0.05  # step height (m)


def _flat_swing(n=200, length=0.3, bump=0.04):
    """A flat plan's swing track over n + 1 samples: x from 0 to ``length`` and a sin² bump of height ``bump``,
    with its exact velocities and accelerations (world, linear then angular)."""
    T = n * DT
    s = np.arange(n + 1) / n
    poses = np.repeat(np.eye(4)[None], n + 1, axis=0)
    poses[:, 0, 3] = length * s
    poses[:, 2, 3] = bump * np.sin(math.pi * s) ** 2
    vels, accs = np.zeros((n + 1, 6)), np.zeros((n + 1, 6))
    vels[:, 0] = length / T
    vels[:, 2] = bump * math.pi / T * np.sin(2 * math.pi * s)
    accs[:, 2] = bump * 2 * math.pi**2 / T**2 * np.cos(2 * math.pi * s)
    return poses, vels, accs


def _blind(track, k, n):
    poses, vels, accs = track
    pose = pin.SE3(poses[k].copy())
    vel, acc = vels[k].copy(), accs[k].copy()
    blind_swing_into(track, k, 0, n, H, DT, pose, vel, acc)
    return pose, vel, acc


def test_blind_swing_reaches_the_foothold_early_and_lifts_by_the_step_height():
    n = 200
    track = _flat_swing(n)
    for k in range(n + 1):
        pose, vel, acc = _blind(track, k, n)
        s = k / n
        if s >= 0.8:  # over the foothold, descending vertically
            assert pose.translation[:2] == pytest_approx([0.3, 0.0])
            assert np.all(vel[:2] == 0.0) and np.all(acc[:2] == 0.0)
        if 0.3 <= s <= 0.6:  # the lift is held at the step height (the flat plan's bump removed)
            assert abs(pose.translation[2] - H) <= 1e-12
    assert abs(_blind(track, n, n)[0].translation[2]) <= 1e-12  # set down on the planned landing height


def test_blind_swing_velocity_is_the_derivative_of_its_position():
    """z velocity and acceleration against central differences of z over the plan samples; x velocity against the
    difference of x (where the horizontal motion runs 1 / 0.8 times faster, away from the rounding of its index)."""
    n = 400
    track = _flat_swing(n)
    z = np.array([_blind(track, k, n)[0].translation[2] for k in range(n + 1)])
    for k in range(5, n - 5):
        _, vel, acc = _blind(track, k, n)
        assert abs(vel[2] - (z[k + 1] - z[k - 1]) / (2 * DT)) <= 1e-3 * max(1.0, abs(vel[2]))
        # the second difference errs by about the jerk times DT (≤ ~0.1 m/s² here; accelerations up to ~3 m/s²)
        assert abs(acc[2] - (z[k + 1] - 2 * z[k] + z[k - 1]) / DT**2) <= 0.2 + 2e-2 * abs(acc[2])
        if k < 0.75 * n:
            assert abs(vel[0] - 0.3 / (n * DT) / 0.8) <= 1e-12


def pytest_approx(x):
    import pytest

    return pytest.approx(x, abs=1e-12)


def test_roll_band_cuts_about_the_measured_pivot_up_to_the_edges():
    half = (0.1, 0.05)
    band, until = [-np.inf, np.inf, -np.inf, np.inf], [-np.inf, -np.inf]
    roll_band(band, until, 1.0, np.array([0.0, 0.7, 0.0]), (0.03, 0.0), half)  # pitching at 0.7 rad/s > 0.6
    assert band[:2] == pytest_approx([0.02, 0.04]) and math.isinf(band[2]) and until == [1.1, -np.inf]
    roll_band(band, until, 1.2, np.array([0.9, 0.0, 0.0]), (0.0, 0.065), half)  # rolling, pivot 1.5 cm outside
    assert band[2:] == [-np.inf, np.inf] and until[1] == -np.inf  # not on the sole (a wrench, not a pivot): no cut
    roll_band(band, until, 1.2, np.array([0.9, 0.0, 0.0]), (0.0, 0.05), half)  # rolling about its side edge
    assert band[2:] == pytest_approx([0.04, 0.06]) and until[1] == 1.2 + 0.1
    roll_band(band, until, 1.2, np.array([0.9, 0.0, 0.0]), (0.0, -0.01), half)
    assert band[2:] == pytest_approx([-0.02, 0.0]) and until[1] == 1.2 + 0.1
    before = list(band)
    roll_band(band, until, 1.3, np.array([0.5, -0.5, 0.0]), (0.0, 0.0), half)  # below the rate: unchanged
    assert band == before


def test_clip_band_range_keeps_two_centimetres_inside_the_sole():
    assert clip_band_range(0.02, 0.03, -0.1, 0.1) == pytest_approx((0.015, 0.035))
    assert clip_band_range(0.095, 0.1, -0.1, 0.1) == pytest_approx((0.08, 0.1))
    assert clip_band_range(-0.05, 0.05, -0.1, 0.1) == (-0.05, 0.05)


# -- a box sole turned onto one edge in MuJoCo: the band holds MuJoCo's contacts -----------------------------------

L, W = 0.21, 0.13  # sole rectangle (m)
_FOOT = box_sole_mjcf(L, W, DT)


def test_a_sole_turning_onto_its_edge_is_cut_to_a_band_holding_mujocos_contacts():
    """A 30 kg box sole on a floor pitched toe-down (8° over 0.1 s): it turns about its toe edge (MuJoCo's contacts
    all at x = +L/2) faster than the roll rate. :func:`roll_band` fed MuJoCo's ground reaction (its CoP, sole frame)
    and the sole's angular velocity cuts the x range to a band that holds MuJoCo's contacts, inside the sole — the
    line the ground supports the sole on, so the QP's CoP asks no torque about it the ground cannot give."""
    model = mujoco.MjModel.from_xml_string(_FOOT)
    data = mujoco.MjData(model)
    site, foot = model.site("sole").id, model.body("foot").id
    band, until = [-np.inf, np.inf, -np.inf, np.inf], [-np.inf, -np.inf]
    checked = 0
    c6 = np.zeros(6)
    for k in range(int(round(0.8 / DT))):
        t = k * DT
        data.ctrl[0] = math.radians(8.0) * min(1.0, max(0.0, (t - 0.5) / 0.1))
        mujoco.mj_step1(model, data)
        mujoco.mj_rnePostConstraint(model, data)
        R, p = data.site_xmat[site].reshape(3, 3), data.site_xpos[site]
        f, tau, pts = np.zeros(3), np.zeros(3), []
        for i in range(data.ncon):
            con = data.contact[i]
            mujoco.mj_contactForce(model, data, i, c6)
            fw = con.frame.reshape(3, 3).T @ c6[:3]
            if model.geom_bodyid[con.geom1] == foot:
                fw = -fw
            f, tau = f + fw, tau + np.cross(con.pos - p, fw)
            pts.append(R.T @ (con.pos - p))
        fs, ts = R.T @ f, R.T @ tau  # ground reaction at the sole origin, sole axes
        omega = R.T @ data.cvel[foot][:3]  # (cvel: rotation first, world axes)
        if fs[2] > 10.0:
            roll_band(band, until, t, omega, (-ts[1] / fs[2], ts[0] / fs[2]), (L / 2, W / 2))
        mujoco.mj_step2(model, data)
        on_edge = pts and all(abs(x[0] - L / 2) < 2e-3 for x in pts)
        if on_edge and abs(omega[1]) > BLIND_ROLL_RATE:
            lo, hi = clip_band_range(max(-L / 2, band[0]), min(L / 2, band[1]), -L / 2, L / 2)
            assert -L / 2 <= lo < hi <= L / 2 and hi - lo <= 0.02 + 1e-12
            assert all(lo - 1e-3 <= x[0] <= hi + 1e-3 for x in pts)  # MuJoCo's contacts inside the band
            checked += 1
    assert checked >= 10  # the sole turned about its edge faster than the rate for at least 20 ms
