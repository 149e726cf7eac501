"""The LIPM/DCM CoM plan (wbc.gait.com_plan): ZMP on its reference within the support, LIPM dynamics against finite differences, continuity, rest at both ends."""

from __future__ import annotations

import numpy as np
import pytest

from gait_plans import any_plan  # noqa: F401 (the fixture)
from gait_plans import PLANS, Z_COM, replanned_plan, straight_plan, talos_size_walk


def test_zmp_equals_reference_and_stays_in_support(any_plan):
    p = any_plan.com[:, :2] - any_plan.com_acc[:, :2] / any_plan.omega**2
    np.testing.assert_allclose(p, any_plan.zmp, rtol=0, atol=1e-9)
    margin = any_plan.zmp_margin()
    assert margin.shape == (any_plan.n_samples,)
    assert margin.min() >= 0.0, f"min ZMP margin {margin.min():.6f} m"


def test_expected_min_margins():
    # Single support keeps the ZMP at the sole centre: margin = half the sole width (0.13 / 2).
    for name in ("straight_8x0.15", "turning", "one_step"):
        assert PLANS[name]().zmp_margin().min() == pytest.approx(0.065, abs=1e-9), name
    assert replanned_plan().zmp_margin().min() > 0.0


def test_lipm_dynamics_against_finite_differences(any_plan):
    c, v, a, dt = any_plan.com, any_plan.com_vel, any_plan.com_acc, any_plan.dt
    np.testing.assert_allclose(a[:, :2], any_plan.omega**2 * (c[:, :2] - any_plan.zmp), rtol=0, atol=1e-9)
    v_fd = (c[2:] - c[:-2]) / (2 * dt)
    a_fd = (c[2:] - 2 * c[1:-1] + c[:-2]) / dt**2
    # Central differences: O(dt²) error, |c'''| dt²/6 ~ 1e-6 m/s. The second difference is O(dt) at segment
    # boundaries where c''' = ω²(ċ − ṗ) jumps with the ZMP slope: dt·ω²·|Δṗ|/6 ≈ 2e-3 m/s².
    assert np.abs(v_fd - v[1:-1]).max() < 1e-5
    assert np.abs(a_fd - a[1:-1]).max() < 5e-3
    assert np.all(c[:, 2] == any_plan.com_height) and np.all(v[:, 2] == 0) and np.all(a[:, 2] == 0)
    np.testing.assert_allclose(any_plan.dcm, c[:, :2] + v[:, :2] / any_plan.omega, atol=1e-12)


def test_com_continuity(any_plan):
    c, v, a, dt = any_plan.com, any_plan.com_vel, any_plan.com_acc, any_plan.dt
    dc = np.linalg.norm(np.diff(c, axis=0), axis=1)
    dv = np.linalg.norm(np.diff(v, axis=0), axis=1)
    assert dc.max() <= dt * np.linalg.norm(v, axis=1).max() * (1 + 1e-6)
    assert dv.max() <= dt * np.linalg.norm(a, axis=1).max() * (1 + 1e-6)
    # Acceleration continuity too: c̈ = ω²(c − p) with c and the ZMP reference p both continuous, so per
    # sample |Δc̈| <= ω² (max|Δc| + max|Δp|); a ZMP jump would break this bound.
    dp = np.linalg.norm(np.diff(any_plan.zmp, axis=0), axis=1)
    da = np.linalg.norm(np.diff(a, axis=0), axis=1)
    assert da.max() <= any_plan.omega**2 * (dc.max() + dp.max()) * (1 + 1e-6)


def test_starts_at_rest_and_settles():
    plan = straight_plan()
    np.testing.assert_allclose(plan.com[0], [0.0, 0.0, Z_COM], atol=1e-12)
    assert np.abs(plan.com_vel[0]).max() < 1e-9
    mid = 0.5 * (plan.left_sole[-1, :2, 3] + plan.right_sole[-1, :2, 3])
    np.testing.assert_allclose(plan.dcm[-1], mid, atol=1e-12)  # terminal DCM on the final ZMP
    np.testing.assert_allclose(plan.zmp[-1], mid, atol=1e-12)
    # The CoM converges to the DCM as e^{-ω t} during the 0.9 s hold: measured |ċ| ≈ 4.2 mm/s, 1.2 mm off.
    assert np.linalg.norm(plan.com_vel[-1]) < 0.006
    assert np.linalg.norm(plan.com[-1, :2] - mid) < 0.002


def test_initial_zmp_inside_start_polygon_and_com_velocity_start():
    plan = talos_size_walk(n_steps=4, com_velocity=np.array([0.05, 0.02, 0.1]))
    assert plan.com_vel[0, :2] == pytest.approx([0.05, 0.02], abs=1e-12)
    assert plan.zmp_margin().min() >= 0.0
