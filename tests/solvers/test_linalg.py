"""The clip of a box into the running box (:func:`wbc.solvers.linalg.clip_entry_into`, :func:`clip_box_into`):
the intersection where the two overlap, else the running box's end nearest the new one (it yields, never empties)."""

import numpy as np

from wbc.solvers.linalg import clip_box_into, clip_entry_into

# (running lb, ub), new (lo, hi) -> expected (lb, ub): written by hand from the rule of the module docstring
CASES = [
    ((-1.0, 1.0), (-0.5, 2.0), (-0.5, 1.0)),  # overlap: the intersection
    ((-1.0, 1.0), (-3.0, -2.0), (-1.0, -1.0)),  # below: pinned at the running lower end
    ((-1.0, 1.0), (2.0, 3.0), (1.0, 1.0)),  # above: pinned at the running upper end
    ((-np.inf, np.inf), (0.25, 0.5), (0.25, 0.5)),  # a free entry takes the new box
    ((0.0, 0.0), (-1.0, 1.0), (0.0, 0.0)),  # a locked entry stays locked
]


def test_clip_entry_into_follows_the_rule():
    for (lb0, ub0), (lo, hi), expected in CASES:
        lb, ub = np.array([7.0, lb0]), np.array([8.0, ub0])
        clip_entry_into(lb, ub, 1, lo, hi)
        assert (lb[1], ub[1]) == expected
        assert (lb[0], ub[0]) == (7.0, 8.0)  # the other entries untouched


def test_clip_box_into_clips_each_entry_from_start():
    lb = np.array([9.0] + [c[0][0] for c in CASES])
    ub = np.array([9.5] + [c[0][1] for c in CASES])
    clip_box_into(lb, ub, 1, np.array([c[1][0] for c in CASES]), np.array([c[1][1] for c in CASES]))
    assert lb.tolist() == [9.0] + [c[2][0] for c in CASES]
    assert ub.tolist() == [9.5] + [c[2][1] for c in CASES]
