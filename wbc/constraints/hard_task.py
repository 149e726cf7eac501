"""A task held as an equality constraint of the inverse-dynamics QP: J v̇ = a* − J̇ v."""

from __future__ import annotations

from wbc.constraints.base import IDConstraint

__all__ = ["HardTask"]


class HardTask(IDConstraint):
    """A task held as a hard equality J v̇ = a* − J̇ v (task units /s²); its weights play no role.

    Args:
        task: an :class:`~wbc.formulations.reference.AccelerationReference` (anything with ``name``, ``dim`` and
            ``compute(state) -> (J, r)``; the formulation checks the type).
    """

    kind = "equality"

    def __init__(self, task):
        self.task = task
        self.name = f"task:{task.name}"
        self.dim = task.dim

    def write(self, ctx, A, b, _):
        J, r = self.task.compute(ctx.state)
        A[:, :ctx.nv] = J
        A[:, ctx.nv:] = 0.0
        b[:] = r
