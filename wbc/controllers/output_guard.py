"""The output guard of a kinematic tick: an ok tick's command is finite and within the box and inequality rows to
the backend's tolerance (checked against the constraint objects' bounds recomputed at the tick, not read from the
solver), and every number of its QP is finite; else the tick fails (``TickResult.reason``) and the safe command is
returned (:mod:`wbc.controllers.recovery`). Pure functions of the tick's arrays."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["command_fault", "qp_data_fault"]


def qp_data_fault(H: np.ndarray, g: np.ndarray, A: np.ndarray, b: np.ndarray, C: np.ndarray, l: np.ndarray,
                  u: np.ndarray, lb: np.ndarray, ub: np.ndarray) -> str:
    """'' when the QP min ½vᵀHv + gᵀv s.t. A v = b, l ≤ C v ≤ u, lb ≤ v ≤ ub has finite numbers (bounds l, u, lb, ub
    may be ±inf, never NaN), else the names of the parts that are not (comma-separated, each once)."""
    what = [name for name, x in (("cost H", H), ("cost g", g), ("equality rows A", A), ("equality rhs b", b),
                                 ("inequality rows C", C)) if not np.isfinite(x).all()]
    what += [name for name, x in (("inequality bounds", l), ("inequality bounds", u), ("box lb", lb), ("box ub", ub))
             if np.isnan(x).any()]
    return ", ".join(dict.fromkeys(what))


def command_fault(v: np.ndarray, lb: np.ndarray, ub: np.ndarray, C: np.ndarray, l: np.ndarray, u: np.ndarray,
                  tol: float) -> str:
    """Output guard of an ok tick: '' when v (n,) is finite, within [lb, ub] (n,) and l ≤ C v ≤ u (C (m, n)) to
    ``tol`` (each bound or row scaled by max(1, |bound|), as
    :meth:`wbc.solvers.base.QPBackend.scaled_violation`; a row also by max(1, |C| |v|)), else what it violates (the
    first box entry of largest scaled excess, else the first such row). The contact rows are held by the
    sole-drift check (``sole_drift_tolerance``), not here."""
    if not math.isfinite(float(v @ v)):
        return "the command v is not finite"
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
