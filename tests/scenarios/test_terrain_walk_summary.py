"""``wbc.scenarios.terrain_walk.terrain_summary``: what a walk on terrain did, measured from executed sole poses.

Oracle: the planner's own clearance of each swing (:func:`wbc.gait.terrain_walk.plan_terrain_walk`, the same
terrain query on the planned poses), the stairs' geometry, and poses built by hand from the plan (shifted sideways,
dipped into a step edge).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from wbc.gait.terrain_walk import plan_terrain_walk
from wbc.scenarios.terrain_walk import terrain_summary

L, W = 0.22, 0.13  # sole (m)


def _stairs_walk():
    left, right = np.eye(4), np.eye(4)
    left[1, 3], right[1, 3] = 0.085, -0.085
    return plan_terrain_walk("stairs:0.1:0.3:3:updown", left, right, np.array([0.0, 0.0, 0.87]), n_steps=10,
                             step_length=0.3, sole_length=L, sole_width=W)


def test_the_planned_walk_measures_its_planned_clearance_and_footholds():
    tw = _stairs_walk()
    s = terrain_summary(tw, tw.plan.left_sole, tw.plan.right_sole, L, W)
    planned = min(c for c in tw.planned_clearance if math.isfinite(c))
    assert s["min_swing_clearance_m"] == pytest.approx(planned, abs=1e-12)
    assert s["max_foothold_error_m"] <= 1e-12
    assert s["max_sole_support_gap_m"] == 0.0


def test_a_walk_landing_beside_its_footholds_is_measured_from_where_it_landed():
    """The executed walk is the plan moved 0.15 m to the left (more than the ``approach`` distance from the planned
    footholds; the treads run along y, so every sole still stands wholly on its tread and crosses the same edges at
    the same heights): the clearance over the edges is the plan's, the descent onto each tread beside its planned
    foothold is not an edge crossing; the foothold error is the 0.15 m shift."""
    tw = _stairs_walk()
    assert tw.approach < 0.15
    left, right = tw.plan.left_sole.copy(), tw.plan.right_sole.copy()
    left[:, 1, 3] += 0.15
    right[:, 1, 3] += 0.15
    s = terrain_summary(tw, left, right, L, W)
    planned = min(c for c in tw.planned_clearance if math.isfinite(c))
    assert s["min_swing_clearance_m"] == pytest.approx(planned, abs=1e-12)
    assert s["max_foothold_error_m"] == pytest.approx(0.15, abs=1e-12)
    assert s["max_sole_support_gap_m"] == 0.0


def test_a_swing_dipped_into_a_step_edge_is_caught():
    """The first step up (a swing from the floor onto the first tread) lowered by its apex plus the rise wherever it
    is more than the approach distance from its lift-off and landing: its sole passes through the first riser's
    edge, and the measured clearance is negative."""
    tw = _stairs_walk()
    ph = next(ph for ph in tw.plan.phases if ph.step >= 0)
    side = tw.plan.footsteps[ph.step].side
    left, right = tw.plan.left_sole.copy(), tw.plan.right_sole.copy()
    P = left if side == "left" else right
    a, b = ph.first, ph.end
    start, land = P[a, :2, 3].copy(), tw.footholds[ph.step][:2, 3]
    for k in range(a, b):
        c = P[k, :2, 3]
        if min(np.linalg.norm(c - start), np.linalg.norm(c - land)) > tw.approach:
            P[k, 2, 3] = 0.05  # below the first tread's top (0.1 m) over its edge
    s = terrain_summary(tw, left, right, L, W)
    assert s["min_swing_clearance_m"] < 0.0
