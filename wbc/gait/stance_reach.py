r"""The stance leg's reach during a single support: when the hip, carried with the CoM, gets as far from the stance
ankle as a stretched leg allows.

With the CoP held at the stance ankle ``a`` (xy, m) the CoM follows the linear inverted pendulum (LIPM; Kajita et al.,
IROS 2001; Englsberger et al., IEEE T-RO 31(2), 2015, eq. 6), ``ω = √(g / z_c)``:

    c(t) = a + (c₀ − a) cosh ωt + (ċ₀ / ω) sinh ωt = a + P x + Q / x,   x = e^{ωt},
    P = ½ (c₀ − a + ċ₀ / ω),   Q = ½ (c₀ − a − ċ₀ / ω).

The hip keeps its horizontal offset ``o`` from the CoM and its height ``h`` over the ankle (the CoM height is held),
so the hip-to-ankle distance is ``r(t)² = |P x + Q / x + o|² + h²``, and ``r = R`` is, multiplied by ``x²``, the
quartic

    |P|² x⁴ + 2 P·o x³ + (|o|² + 2 P·Q + h² − R²) x² + 2 Q·o x + |Q|² = 0,

whose least real root ``x ≥ 1`` gives the time ``t = ln x / ω`` (0 when ``r ≥ R`` already, ∞ when it never comes).

**Why it bounds the step time.** Near full extension a leg's knee turns fast for a small change of its length: with
thigh ``l₁``, shank ``l₂`` and knee angle θ (0: straight), ``r² = l₁² + l₂² + 2 l₁ l₂ cos θ`` and ``ṙ = −l₁ l₂ sin θ θ̇
/ r``: at θ = 0.3 rad (Talos, l₁ = 0.38 m, l₂ = 0.325 m: r = 0.99 r_max) the knee at its 7 rad/s limit lengthens the leg
by only 0.37 m/s. A push that carries the CoM away from the stance foot while the swing is long stretches the stance leg
to its end; the robot then drops onto the landing leg, whose knee, and the stance knee braking at its position limit,
pass their speed limits (benchmarks/records/67). :class:`~wbc.sim.walk.WalkScenario` therefore lands a swing whose step
time the QP of :mod:`wbc.gait.step_timing` adapts no later than the stance leg reaches ``R = ρ r_max`` (its
``reach_ratio`` ρ, :data:`STANCE_REACH_RATIO`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from wbc.exceptions import InvalidInputError

__all__ = ["StanceLeg", "STANCE_REACH_RATIO", "stance_legs", "stance_reach_time"]

#: ρ: the fraction of a leg's full length r_max (hip to ankle, knee straight) at which the stance leg's reach ends
#: (module docstring): 0.97 (Talos: knee at 0.49 rad), chosen by hand, not swept (benchmarks/records/67).
STANCE_REACH_RATIO = 0.97


class StanceLeg(NamedTuple):
    """One leg of :func:`stance_legs`."""

    hip: int      #: Pinocchio joint index of the leg's first joint below the floating base (its ``oMi`` is the hip)
    ankle: int    #: joint index of the sole frame's parent joint (its ``oMi`` is the ankle)
    length: float  #: r_max (m): the hip-to-ankle distance with the leg stretched


def stance_legs(robot) -> dict[str, StanceLeg]:
    """``{"left", "right"}`` → :class:`StanceLeg` of the robot's legs (the joints from the floating base to each sole
    frame). ``length`` is the longest path hip → joint → ankle over the leg's joints at ``robot.q_ref`` (thigh +
    shank when the joint is the knee), so it does not depend on the posture the robot file calls neutral.

    Raises:
        InvalidInputError: a sole frame with no joint between it and the floating base.
    """
    model = robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, robot.q_ref)
    out = {}
    for side, sole in (("left", robot.left_sole), ("right", robot.right_sole)):
        ankle = model.frames[robot.frame_id(sole)].parentJoint
        chain = [j for j in model.supports[ankle] if model.joints[j].idx_v >= 6]
        if not chain:
            raise InvalidInputError(f"{side} sole frame {sole!r} hangs from no joint below the floating base")
        ph, pa = data.oMi[chain[0]].translation, data.oMi[ankle].translation
        length = max(float(np.linalg.norm(data.oMi[j].translation - ph) + np.linalg.norm(pa - data.oMi[j].translation))
                     for j in chain)
        out[side] = StanceLeg(chain[0], ankle, length)
    return out


def stance_reach_time(com, com_velocity, omega: float, hip, ankle, reach: float) -> float:
    """Time (s, from now) at which the stance leg's hip-to-ankle distance reaches ``reach`` R (m) on the LIPM about
    its ankle (module docstring): 0 when it is there already, ``inf`` when the CoM never takes it there.

    Args:
        com: (≥ 2,) CoM position (m, world; x, y read). com_velocity: (≥ 2,) its velocity (m/s).
        omega: ω = √(g / z_c) (1/s, > 0).
        hip: (3,) hip position (m, world). ankle: (3,) ankle position (m, world), the LIPM's CoP (xy).
        reach: R (m, > 0).

    Raises:
        InvalidInputError: ω or R not a finite number > 0; a position or velocity not finite or too short.
    """
    if not (math.isfinite(omega) and omega > 0 and math.isfinite(reach) and reach > 0):
        raise InvalidInputError(f"omega and reach must be finite numbers > 0, got {omega!r}, {reach!r}")
    a, hp = np.asarray(ankle, float).ravel(), np.asarray(hip, float).ravel()
    c0, cd = np.asarray(com, float).ravel()[:2], np.asarray(com_velocity, float).ravel()[:2]
    if a.size < 3 or hp.size < 3 or c0.size < 2 or cd.size < 2 or not (
            np.isfinite(a[:3]).all() and np.isfinite(hp[:3]).all() and np.isfinite(c0).all() and np.isfinite(cd).all()):
        raise InvalidInputError(f"com, com_velocity (≥ 2 finite numbers), hip and ankle (≥ 3) expected, got {com!r}, "
                                f"{com_velocity!r}, {hip!r}, {ankle!r}")
    d0 = c0 - a[:2]
    o = hp[:2] - c0
    h2 = float(hp[2] - a[2]) ** 2
    if float((d0 + o) @ (d0 + o)) + h2 >= reach * reach:
        return 0.0
    w = cd / omega
    P, Q = 0.5 * (d0 + w), 0.5 * (d0 - w)
    roots = np.roots([P @ P, 2.0 * P @ o, o @ o + 2.0 * P @ Q + h2 - reach * reach, 2.0 * Q @ o, Q @ Q])
    real = roots.real[(np.abs(roots.imag) <= 1e-9 * np.maximum(1.0, np.abs(roots))) & (roots.real >= 1.0)]
    return float(math.log(real.min()) / omega) if real.size else math.inf
