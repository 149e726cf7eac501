"""The support schedule (wbc.gait.schedule): phases of a walk on the sample grid and the ZMP reference segments,
against the walk written out by hand."""

from __future__ import annotations

import math

import numpy as np

from wbc.gait.footsteps import Footstep
from wbc.gait.schedule import DOUBLE_SUPPORT, LEFT_SUPPORT, RIGHT_SUPPORT, Support, build_phases, zmp_segments


def test_phases_tile_the_grid_and_alternate_the_swinging_foot():
    phases = build_phases(3, "left", 10, [20, 21, 22], [5, 6, 7], 30, 0.01)
    assert [p.support for p in phases] == [DOUBLE_SUPPORT, RIGHT_SUPPORT, DOUBLE_SUPPORT, LEFT_SUPPORT,
                                          DOUBLE_SUPPORT, RIGHT_SUPPORT, DOUBLE_SUPPORT]
    assert [p.count for p in phases] == [10, 20, 5, 21, 6, 22, 30]  # the last step's double support is n_final
    assert [p.first for p in phases] == [0, 10, 30, 35, 56, 62, 84]
    assert [p.step for p in phases] == [-1, 0, -1, 1, -1, 2, -1]
    assert all(a.first + a.count == b.first for a, b in zip(phases, phases[1:]))
    right_first = build_phases(1, "right", 4, 8, 2, 6, 0.01)
    assert right_first[1].support == LEFT_SUPPORT and Support(LEFT_SUPPORT) is Support.LEFT


def test_zmp_segments_follow_the_stance_feet_and_end_at_their_middle():
    left, right = (0.0, 0.1), (0.0, -0.1)
    steps = [Footstep("left", 0.2, 0.1, 0.0), Footstep("right", 0.4, -0.1, 0.0)]
    phases = build_phases(2, "left", 10, 20, 5, 30, 0.01)
    seg = zmp_segments(phases, steps, left, right, 12)
    # initial DS: (undefined) → first stance foot (right); SS on the right; DS right → left (moved: 0.2, 0.1);
    # SS on the left; final DS: ramp from the left foot to the mid-point of the feet in 12 samples, then hold
    expected_end = [right, right, (0.2, 0.1), (0.2, 0.1), (0.3, 0.0), (0.3, 0.0)]
    np.testing.assert_allclose(seg.end, expected_end, atol=1e-15)
    assert all(math.isnan(x) for x in seg.start[0])
    np.testing.assert_allclose(seg.start[1:], [right, right, (0.2, 0.1), (0.2, 0.1), (0.3, 0.0)], atol=1e-15)
    assert seg.first.tolist() == [0, 10, 30, 35, 55, 67] and seg.count.tolist() == [10, 20, 5, 20, 12, 18]
    assert seg.phase.tolist() == [0, 1, 2, 3, 4, 4]
