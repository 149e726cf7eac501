""":mod:`wbc.gait.blind`: the blind swing and the partial-foothold band, without a simulator. The swing is checked
against its own definition (foothold reached at 80 % of the swing, lift held between 30 % and 60 %) and its
velocities against finite differences of its positions; the band against cases worked by hand (numbers written
here)."""

import math

import numpy as np
import pinocchio as pin

from wbc.gait.blind import blind_swing_into, clip_band_range, roll_band

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


def test_roll_band_cuts_about_an_inner_pivot_only():
    half = (0.1, 0.05)
    band, until = [-np.inf, np.inf, -np.inf, np.inf], [-np.inf, -np.inf]
    roll_band(band, until, 1.0, np.array([0.0, 0.7, 0.0]), (0.03, 0.0), half)  # pitching at 0.7 rad/s > 0.6
    assert band[:2] == pytest_approx([0.02, 0.04]) and math.isinf(band[2]) and until == [1.1, -np.inf]
    roll_band(band, until, 1.2, np.array([0.9, 0.0, 0.0]), (0.0, 0.035), half)  # rolling, pivot 1.5 cm inside
    assert band[2:] == [-np.inf, np.inf] and until[1] == -np.inf  # not 2 cm inside the side edge: no cut
    roll_band(band, until, 1.2, np.array([0.9, 0.0, 0.0]), (0.0, -0.01), half)
    assert band[2:] == pytest_approx([-0.02, 0.0]) and until[1] == 1.2 + 0.1
    before = list(band)
    roll_band(band, until, 1.3, np.array([0.5, -0.5, 0.0]), (0.0, 0.0), half)  # below the rate: unchanged
    assert band == before


def test_clip_band_range_keeps_two_centimetres_inside_the_sole():
    assert clip_band_range(0.02, 0.03, -0.1, 0.1) == pytest_approx((0.015, 0.035))
    assert clip_band_range(0.095, 0.1, -0.1, 0.1) == pytest_approx((0.08, 0.1))
    assert clip_band_range(-0.05, 0.05, -0.1, 0.1) == (-0.05, 0.05)
