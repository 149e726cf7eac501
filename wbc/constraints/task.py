"""A task held as a hard equality: J v = v* (the task's own rows, gain and feed-forward).

Used by ``KinematicController.add_task(task, hard=True)``. The rows are the task's Jacobian J (m, nv) and its
velocity target v* = ė* − K e (task units per second); the task's weights play no role. If the hard rows conflict
with other hard constraints the tick fails and the conflict report names the task (``task.name``).
"""

from __future__ import annotations

import numpy as np

from wbc.configuration import Configuration
from wbc.constraints.base import EqualityConstraint
from wbc.tasks.base import Task

__all__ = ["TaskConstraint"]


class TaskConstraint(EqualityConstraint):
    """Equality constraint J v = v* built from ``task`` (module docstring). ``name`` and ``dim`` are the task's."""

    def __init__(self, task: Task):
        self.task = task
        self.name = task.name
        self.dim = task.dim

    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray]:
        error, jac = self.task.compute(config)
        return jac, self.task.velocity_target(error)
