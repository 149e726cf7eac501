"""Joint-velocity damping task: e ≡ 0, J = identity rows on v, i.e. the cost Σ_j w_j v_j².

This is a velocity-level regulariser, not a configuration error: it has no e(q) to differentiate (the finite-
difference check of the other tasks does not apply; ``tests/tasks/test_damping.py`` checks that it adds exactly
w_j to the diagonal of H and nothing to g). Unlike the controller's ``damping`` ε (a numerical regulariser that
only keeps H positive definite), it is a task: it can sit on any level of a hierarchy and be weighted per joint.
"""

from __future__ import annotations

import numpy as np

from wbc.configuration import Configuration
from wbc.tasks.base import Task

__all__ = ["DampingTask"]


class DampingTask(Task):
    """Penalise the generalized velocity: cost Σ_j w_j v_j² (J v = 0 with J = selected rows of I).

    Args:
        robot: the robot.
        weight: scalar or (dim,) weights (s²·rad⁻² per (rad/s)², i.e. per unit of v²).
        actuated_only: True: rows for the actuated joints only, v[6:] (dim = nv − 6); False (default): every
            coordinate of v, the floating base too (dim = nv).
        name: label (default ``"damping"``).

    Attributes:
        nv: size of v of the robot it was built for (a controller of another robot rejects the task).
        rows: (dim,) indices of the penalised coordinates of v.

    Raises:
        InvalidInputError: bad weight.
    """

    name = "damping"

    def __init__(self, robot, *, weight=1e-3, actuated_only: bool = False, name: str | None = None):
        nv = robot.model.nv
        self.nv = nv
        self.rows = np.arange(6 if actuated_only else 0, nv)
        self.dim = int(self.rows.size)
        super().__init__(gain=0.0, weight=weight, name=name)
        self._jac = np.zeros((self.dim, nv))
        self._jac[np.arange(self.dim), self.rows] = 1.0
        self._zero = np.zeros(self.dim)

    def compute(self, config: Configuration) -> tuple[np.ndarray, np.ndarray]:
        """(zeros (dim,), selection matrix (dim, nv))."""
        return self._zero, self._jac

    def drift(self, state) -> np.ndarray:
        """(dim,) zeros: J is a constant selection."""
        return self._zero

    def add_cost(self, config: Configuration, H: np.ndarray, g: np.ndarray) -> None:
        """H[j, j] += w_j on the selected coordinates; g unchanged (v* = 0)."""
        H[self.rows, self.rows] += self._weight
