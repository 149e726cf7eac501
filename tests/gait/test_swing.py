"""Swing-foot trajectories (wbc.gait.swing): lift-off and landing poses exact, feet constant between swings."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.gait import DOUBLE_SUPPORT, LEFT_SUPPORT, plan_walk
from gait_plans import HALF_WIDTH, PLANS, Z_COM, pose, rot_fd


@pytest.mark.parametrize("name", ["straight_8x0.15", "turning"])
def test_swing_trajectories(name):
    plan = PLANS[name]()
    h = 0.05
    for ph in plan.phases:
        if ph.support == DOUBLE_SUPPORT:
            continue
        swing_side = "right" if ph.support == LEFT_SUPPORT else "left"
        sw = getattr(plan, f"{swing_side}_sole")
        sw_v = getattr(plan, f"{swing_side}_sole_vel")
        st = getattr(plan, f"{'left' if swing_side == 'right' else 'right'}_sole")
        st_v = getattr(plan, f"{'left' if swing_side == 'right' else 'right'}_sole_vel")
        lo, td = ph.first, ph.end
        # Zero velocity at lift-off and touch-down; the stance foot does not move at all.
        assert np.all(sw_v[lo] == 0.0) and np.all(sw_v[td] == 0.0)
        assert np.all(st[lo:td + 1] == st[lo]) and np.all(st_v[lo:td + 1] == 0.0)
        # Lands exactly on the footstep; clearance peaks at h mid-swing.
        assert np.array_equal(sw[td], plan.footsteps[ph.step].pose())
        assert sw[lo:td + 1, 2, 3].max() == pytest.approx(h, abs=1e-3)
        assert sw[(lo + td) // 2, 2, 3] == pytest.approx(h, abs=1e-12)
        # Analytic velocities match central differences of the poses.
        seg = slice(lo, td + 1)
        v_fd = (sw[seg][2:, :3, 3] - sw[seg][:-2, :3, 3]) / (2 * plan.dt)
        assert np.abs(v_fd - sw_v[seg][1:-1, :3]).max() < 2e-4
        w_fd = rot_fd(sw[seg][:, :3, :3], plan.dt)
        assert np.abs(w_fd - sw_v[seg][1:-1, 3:]).max() < 2e-4
        # Swing rotations stay orthonormal.
        R = sw[seg][:, :3, :3]
        assert np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max() < 1e-12


def test_feet_poses_exact_at_ends_and_constant_between_swings():
    L0, R0 = pose(0.0, HALF_WIDTH), pose(0.0, -HALF_WIDTH)
    plan = plan_walk(L0, R0, np.array([0.0, 0.0, Z_COM]), n_steps=5, step_length=0.12)
    assert np.array_equal(plan.left_sole[0], L0) and np.array_equal(plan.right_sole[0], R0)
    last = {fs.side: fs for fs in plan.footsteps}
    assert np.array_equal(plan.left_sole[-1], last["left"].pose())
    assert np.array_equal(plan.right_sole[-1], last["right"].pose())
    swinging = {"left": np.zeros(plan.n_samples, bool), "right": np.zeros(plan.n_samples, bool)}
    for ph in plan.phases:
        if ph.step >= 0:
            swinging[plan.footsteps[ph.step].side][ph.first + 1:ph.end] = True
    for side in ("left", "right"):
        poses, vel = getattr(plan, f"{side}_sole"), getattr(plan, f"{side}_sole_vel")
        rest = ~swinging[side]
        changes = np.flatnonzero(np.any(poses[1:] != poses[:-1], axis=(1, 2)) & rest[1:] & rest[:-1])
        assert changes.size == 0
        assert np.all(vel[rest] == 0.0)
