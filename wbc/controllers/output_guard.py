"""The output guard of a kinematic tick: an ok tick's command is finite and within the box and inequality rows to
the backend's tolerance (checked against the constraint objects' bounds recomputed at the tick, not read from the
solver), and every number of its QP is finite; else the tick fails (``TickResult.reason``) and the safe command is
returned (:mod:`wbc.controllers.recovery`)."""

from __future__ import annotations

import math

import numpy as np



class OutputGuard:
    """The output-guard part of :class:`wbc.controllers.kinematic.KinematicController` (module docstring)."""

    def _data_fault(self) -> str:
        """'' when the assembled QP's numbers are finite (bounds may be ±inf, never NaN), else what is not."""
        what = [name for name, x in (("cost H", self._H), ("cost g", self._g), ("equality rows A", self._A),
                                     ("equality rhs b", self._b), ("inequality rows C", self._C))
                if not np.isfinite(x).all()]
        what += [name for name, x in (("inequality bounds", self._l), ("inequality bounds", self._u),
                                      ("box lb", self._lb), ("box ub", self._ub)) if np.isnan(x).any()]
        return ", ".join(dict.fromkeys(what))

    def _command_fault(self, v: np.ndarray, lb: np.ndarray, ub: np.ndarray, C: np.ndarray, l: np.ndarray,
                       u: np.ndarray) -> str:
        """Output guard of an ok tick: '' when v is finite, within [lb, ub] and l ≤ C v ≤ u to the backend's
        tolerance (each bound or row scaled by max(1, |bound|), as :meth:`wbc.solvers.base.QPBackend.scaled_violation`),
        else what it violates. The contact rows are held by the sole-drift check (``sole_drift_tolerance``)."""
        if not math.isfinite(float(v @ v)):
            return "the command v is not finite"
        tol = self.backend.tolerance
        over = np.maximum(lb - v, v - ub)
        if not (over.max(initial=-math.inf) <= tol):
            excess = over / np.maximum(1.0, np.maximum(np.abs(np.where(np.isfinite(lb), lb, 0.0)),
                                                       np.abs(np.where(np.isfinite(ub), ub, 0.0))))
            k = int(np.nanargmax(np.where(np.isnan(excess), np.inf, excess)))
            if not excess[k] <= tol:
                return (f"v[{k}] = {v[k]:.6g} outside its bounds [{lb[k]:.6g}, {ub[k]:.6g}] (tolerance {tol:.3g})")
        if C.shape[0]:
            cv = C @ v
            scale = np.maximum(1.0, np.abs(C) @ np.abs(v))
            over = np.maximum(l - cv, cv - u) / np.maximum(scale, np.maximum(
                np.abs(np.where(np.isfinite(l), l, 0.0)), np.abs(np.where(np.isfinite(u), u, 0.0))))
            if not (over.max() <= tol):
                k = int(np.nanargmax(np.where(np.isnan(over), np.inf, over)))
                return f"inequality row {k}: C v = {cv[k]:.6g} outside [{l[k]:.6g}, {u[k]:.6g}] (tolerance {tol:.3g})"
        return ""
