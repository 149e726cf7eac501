"""Time profiles shared by the gait planner and every scenario: the minimum-jerk blend.

Minimum-jerk blend (Flash & Hogan, "The coordination of arm movements: an experimentally confirmed mathematical
model", J. Neurosci. 5(7), 1985, eq. 2 with zero boundary velocity and acceleration):

    b(s) = 10 s³ − 15 s⁴ + 6 s⁵,   b'(s) = 30 s² − 60 s³ + 30 s⁴,   b''(s) = 60 s − 180 s² + 120 s³,

for the normalised time s ∈ [0, 1] (clamped outside): b goes from 0 to 1 with zero velocity and acceleration at
both ends. A move from a to b over T seconds is ``a + b(s) (b − a)`` with s = (t − t0)/T, velocity ``b'(s)/T``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["min_jerk", "min_jerk_ramp"]


def min_jerk(s):
    """Minimum-jerk blend and its derivatives at normalised time ``s`` (module docstring).

    Args:
        s: float or array of normalised times (dimensionless), clamped to [0, 1].

    Returns:
        ``(b, db/ds, d²b/ds²)``: floats for a float ``s``, arrays of ``s``'s shape for an array.
    """
    if isinstance(s, np.ndarray):
        s = np.clip(s, 0.0, 1.0)
    else:
        s = min(max(s, 0.0), 1.0)
    return (10 * s**3 - 15 * s**4 + 6 * s**5, 30 * s**2 - 60 * s**3 + 30 * s**4, 60 * s - 180 * s**2 + 120 * s**3)


def min_jerk_ramp(t: float, t0: float, duration: float) -> tuple[float, float]:
    """Minimum-jerk ramp from 0 to 1 over [t0, t0 + duration] (s): ``(b(s), ds/dt)`` with s = (t − t0)/duration
    clamped to [0, 1]; ds/dt in 1/s, zero outside the ramp. A ``duration`` ≤ 0 is a step at t0."""
    if duration <= 0:
        return (1.0 if t >= t0 else 0.0), 0.0
    tau = (t - t0) / duration
    if tau <= 0.0:
        return 0.0, 0.0
    if tau >= 1.0:
        return 1.0, 0.0
    b, db, _ = min_jerk(tau)
    return b, db / duration
