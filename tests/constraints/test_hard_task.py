"""A task held as an equality of the inverse-dynamics QP (wbc.constraints.hard_task): rows [J 0] x = a* − J̇v from
the task reference's own (J, r), over stale numbers, with the task's name and size."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from wbc.constraints.base import IDContext
from wbc.constraints.hard_task import HardTask


def test_rows_are_the_reference_rows_with_zero_force_columns():
    rng = np.random.default_rng(2)
    J, r = rng.standard_normal((3, 5)), rng.standard_normal(3)
    seen = []
    task = SimpleNamespace(name="hand", dim=3, compute=lambda state: (seen.append(state), (J, r))[1])
    con = HardTask(task)
    assert con.name == "task:hand" and con.dim == 3 and con.kind == "equality"
    A, b = np.full((3, 9), 7.0), np.zeros(3)
    state = object()
    con.write(IDContext(state, 0.002, 5, np.zeros((5, 4)), {}), A, b, None)
    np.testing.assert_array_equal(A, np.hstack([J, np.zeros((3, 4))]))
    np.testing.assert_array_equal(b, r)
    assert seen == [state]
