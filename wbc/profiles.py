"""Time profiles shared by the gait planner and every scenario: the minimum-jerk blend and the ramped trapezoid.

Minimum-jerk blend (Flash & Hogan, "The coordination of arm movements: an experimentally confirmed mathematical
model", J. Neurosci. 5(7), 1985, eq. 2 with zero boundary velocity and acceleration):

    b(s) = 10 s³ − 15 s⁴ + 6 s⁵,   b'(s) = 30 s² − 60 s³ + 30 s⁴,   b''(s) = 60 s − 180 s² + 120 s³,

for the normalised time s ∈ [0, 1] (clamped outside): b goes from 0 to 1 with zero velocity and acceleration at
both ends. A move from a to b over T seconds is ``a + b(s) (b − a)`` with s = (t − t0)/T, velocity ``b'(s)/T``.
Its peak velocity is b'(½) = 1.875 times the average.

Ramped trapezoid: a trapezoidal velocity profile whose ramps, over the fractions ``r`` ∈ (0, ½] of the move at each
end, are half cosine waves, so that the velocity and the acceleration are continuous and both are zero at the ends
(as the minimum-jerk blend's):

    b'(s) = g(s) / (1 − r),   g(s) = ½ (1 − cos(π s / r)) for s < r,  1 in between,  g(1 − s) for s > 1 − r,

    b(s) = (s/2 − r/(2π) sin(π s / r)) / (1 − r) for s < r,  (s − r/2) / (1 − r) in between,
    b(s) = 1 − b(1 − s) for s > 1 − r.

Its peak velocity is 1/(1 − r) times the average (1.43 at r = 0.3), its peak acceleration b'' = π / (2 r (1 − r))
(7.5 at r = 0.3, against the minimum-jerk blend's 5.77): for a given duration it asks a lower top speed and a higher
acceleration. ``r = ½`` is the cosine bell (peak velocity 2).
"""

from __future__ import annotations

import numpy as np

from wbc.exceptions import InvalidInputError

__all__ = ["min_jerk", "min_jerk_ramp", "ramped_trapezoid"]


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


def ramped_trapezoid(s, ramp: float):
    """Ramped trapezoid blend and its derivatives (module docstring) at normalised times ``s``.

    Args:
        s: (n,) array of normalised times (dimensionless), clamped to [0, 1].
        ramp: r, the fraction of the move over which the velocity ramps up (and down), 0 < r ≤ 0.5.

    Returns:
        ``(b, db/ds, d²b/ds²)``, arrays of ``s``'s shape.

    Raises:
        InvalidInputError: ``ramp`` not a number in (0, 0.5].
    """
    if isinstance(ramp, bool) or not isinstance(ramp, (int, float, np.floating)) or not 0.0 < ramp <= 0.5:
        raise InvalidInputError(f"ramp must be a number in (0, 0.5], got {ramp!r}")
    s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
    head, tail = s < ramp, s > 1.0 - ramp
    mid = ~(head | tail)
    g, dg, b = np.ones_like(s), np.zeros_like(s), np.empty_like(s)
    sh, st = s[head], 1.0 - s[tail]  # (the distance to the nearer end, on the ramps)
    g[head] = 0.5 * (1.0 - np.cos(np.pi * sh / ramp))
    g[tail] = 0.5 * (1.0 - np.cos(np.pi * st / ramp))
    dg[head] = np.pi / (2.0 * ramp) * np.sin(np.pi * sh / ramp)
    dg[tail] = -np.pi / (2.0 * ramp) * np.sin(np.pi * st / ramp)
    b[head] = sh / 2 - ramp / (2 * np.pi) * np.sin(np.pi * sh / ramp)
    b[mid] = ramp / 2 + (s[mid] - ramp)
    b[tail] = (1 - ramp) - (st / 2 - ramp / (2 * np.pi) * np.sin(np.pi * st / ramp))
    return b / (1 - ramp), g / (1 - ramp), dg / (1 - ramp)
