"""Capturability of a pushed humanoid in the linear inverted pendulum (LIPM): whether a push can be stopped with
0, 1, …, N steps by a robot of the given step reach and step time, whatever its controller.

Source: Koolen, de Boer, Rebula, Goswami, Pratt, "Capturability-based analysis and control of legged locomotion,
Part 1: Theory and application to three simple gait models", IJRR 31(9), 2012 — the 3D-LIPM with a point foot and
with a finite-sized foot. World frame, z up; every position and distance below is horizontal (x, y) in m.

**Model.** The CoM c at the constant height z₀ above the support, ω = √(g/z₀) (1/s), the CoP p inside the stance
sole(s), a horizontal force F (N) on the CoM: c̈ = ω²(c − p) + F/m. The instantaneous capture point (the paper's
r_ic; the DCM) ξ = c + ċ/ω obeys ξ̇ = ω(ξ − p + F/(mω²)).

**The push as a jump of the capture point.** With F constant over [0, T] and zero after,
e^{−ωt} ξ(t) = ξ(0) + (1 − e^{−ωT}) F/(mω²) − ∫₀ᵗ ω e^{−ωs} p(s) ds for every t ≥ T: the push acts on every later
state exactly as an instantaneous jump of the capture point at its onset,

    Δξ = (1 − e^{−ωT}) F / (m ω²)          (→ F T / (m ω) = Δċ/ω for a short push),

so capturability after the push is that of the state ξ(0) + Δξ at the onset (:func:`push_capture_shift`).

**N-step capture regions.** A step may land anywhere within ℓ_max (m) of the stance sole's centre (the ankle), the
first at ``t_first`` s from the push onset (the swing in progress: the time left to its touch-down; from double
support: a whole swing), each later one Δt_s s after the previous (the shortest step: swing + double support).
While a sole S (a rectangle, centred on its ankle) is the support, the set of capture points reachable after t from
ξ₀ with the CoP anywhere in S is e^{ωt} ξ₀ − (e^{ωt} − 1) S (a convex S: the CoP's weighted mean over time is a point
of S). Writing the N-step capture region about the stance ankle as the Minkowski sum S ⊕ d_N·B (B the unit disc),
the recursion of the paper for the finite-sized foot,

    d_N = (ℓ_max − r_max + d_{N−1}) e^{−ω Δt_s} + r_max,  d_0 = r_max     (r_max: a disc foot's radius)

holds for the rectangle as S ⊕ β_N B, β_0 = 0, β_k = (ℓ_max + β_{k−1}) e^{−ω Δt_s} (the rectangle's scaled copies
sum to itself: e^{−ωΔt}((e^{ωΔt} − 1) S ⊕ S) = S), and for the first step taken at ``t_first``:

    β'_N = (ℓ_max + β_{N−1}) e^{−ω t_first},   β_∞ = ℓ_max e^{−ω Δt_s} / (1 − e^{−ω Δt_s}).

A state is **N-step capturable** when the distance from ξ (after the push's jump) to the stance sole is at most
β'_N; **0-step capturable** when ξ lies in the support (the stance sole, or the convex hull of both soles in double
support) — the capture point inside the sole (Pratt, Carff, Drakunov, Goswami, "Capture point: a step toward
humanoid push recovery", Humanoids 2006).

Assumptions (each makes the region larger, i.e. the verdict is the LIPM's best case): the step lands anywhere in
the disc of radius ℓ_max about the stance ankle, the same in every direction (no leg crossing or hip-width limit),
with the stance sole's yaw; the CoM stays at z₀; no angular momentum (hip strategy) is counted; from double
support either sole may be the one that stays, and the hull of both is the support only without a step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wbc.constants import GRAVITY
from wbc.exceptions import InvalidInputError
from wbc.geometry import convex_hull, signed_distance, sole_polygon

__all__ = ["CaptureModel", "Capturability", "push_capture_shift", "capture_margins", "sole_distance",
           "capturability", "CAPTURE_STEPS_MAX"]

#: Steps the classification tries beyond 0 by default (β_N converges: a fourth step adds e^{−3ωΔt_s} of a step).
CAPTURE_STEPS_MAX = 3


def _positive(x, what: str, unit: str, *, zero: bool = False) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{what} must be a number ({unit}), got {x!r}") from None
    if not math.isfinite(v) or v < 0.0 or (v == 0.0 and not zero):
        raise InvalidInputError(f"{what} must be finite and {'≥ 0' if zero else '> 0'} {unit}, got {x!r}")
    return v


def _xy(x, what: str) -> np.ndarray:
    a = np.asarray(x, dtype=float).ravel()
    if a.size not in (2, 3) or not np.all(np.isfinite(a)):
        raise InvalidInputError(f"{what} must be 2 or 3 finite numbers (world x, y[, z]), got {x!r}")
    return a[:2].copy()


@dataclass(frozen=True)
class CaptureModel:
    """The LIPM of a robot for capturability (module docstring).

    Attributes:
        mass: kg. com_height: z₀, m above the soles. gravity: m/s².
        sole_length, sole_width: the sole rectangle (m), centred on the ankle (the sole frame), x forward.
        step_max: ℓ_max, the largest distance (m) from the stance ankle to the next (the legs' reach).
        step_time: Δt_s, the shortest time (s) from one touch-down to the next (swing + double support).
        swing_time: the shortest swing (s): the first touch-down from double support.
    """

    mass: float
    com_height: float
    sole_length: float
    sole_width: float
    step_max: float
    step_time: float
    swing_time: float
    gravity: float = GRAVITY

    def __post_init__(self):
        for name, unit in (("mass", "kg"), ("com_height", "m"), ("sole_length", "m"), ("sole_width", "m"),
                           ("step_time", "s"), ("swing_time", "s"), ("gravity", "m/s²")):
            _positive(getattr(self, name), f"CaptureModel.{name}", unit)
        _positive(self.step_max, "CaptureModel.step_max", "m", zero=True)
        if self.swing_time > self.step_time:
            raise InvalidInputError(f"CaptureModel.swing_time ({self.swing_time} s) must be ≤ step_time "
                                    f"({self.step_time} s: swing + double support)")

    @property
    def omega(self) -> float:
        """ω = √(g / z₀), 1/s."""
        return math.sqrt(self.gravity / self.com_height)

    @classmethod
    def of_robot(cls, robot, step_time: float, swing_time: float, *, step_max: float | None = None) -> CaptureModel:
        """The model of ``robot`` at its reference posture ``q_ref``: its mass, the CoM height above the lower
        sole, its sole rectangle, ℓ_max = :func:`wbc.analysis.legs.leg_reach` (unless ``step_max``, m) and the
        gait's step and swing times (s)."""
        import pinocchio as pin

        from wbc.analysis.legs import leg_reach

        model = robot.model
        data = model.createData()
        com = pin.centerOfMass(model, data, robot.q_ref)
        pin.framesForwardKinematics(model, data, robot.q_ref)
        sole_z = min(float(data.oMf[robot.frame_id(f)].translation[2]) for f in (robot.left_sole, robot.right_sole))
        return cls(mass=float(robot.mass), com_height=float(com[2]) - sole_z, sole_length=float(robot.sole_length),
                   sole_width=float(robot.sole_width), step_max=leg_reach(robot) if step_max is None else step_max,
                   step_time=step_time, swing_time=swing_time, gravity=float(robot.gravity))


def push_capture_shift(model: CaptureModel, force, duration: float) -> np.ndarray:
    """The capture-point jump Δξ = (1 − e^{−ωT}) F/(mω²) (m, world (2,)) equivalent to a horizontal force ``force``
    (N, world (2,) or (3,); its z ignored) held for ``duration`` T (s) (module docstring).

    Raises:
        InvalidInputError: a force that is not 2 or 3 finite numbers, a negative or non-finite duration.
    """
    f = _xy(force, "force")
    t = _positive(duration, "push duration", "s", zero=True)
    w = model.omega
    return (1.0 - math.exp(-w * t)) * f / (model.mass * w * w)


def capture_margins(model: CaptureModel, t_first: float, n_max: int = CAPTURE_STEPS_MAX) -> np.ndarray:
    """β'_N for N = 0 … ``n_max`` (m): how far outside the stance sole the capture point may be for the state to be
    N-step capturable, the first step landing ``t_first`` s from now (module docstring; β'_0 = 0).

    Raises:
        InvalidInputError: ``t_first`` negative or not finite, ``n_max`` not an integer ≥ 0.
    """
    t1 = _positive(t_first, "t_first (time to the first touch-down)", "s", zero=True)
    if isinstance(n_max, bool) or not isinstance(n_max, (int, np.integer)) or n_max < 0:
        raise InvalidInputError(f"n_max must be an integer ≥ 0, got {n_max!r}")
    w, ell = model.omega, model.step_max
    e = math.exp(-w * model.step_time)
    out = np.zeros(int(n_max) + 1)
    beta = 0.0  # β_{N−1}: the later steps' margin, each Δt_s apart
    for n in range(1, int(n_max) + 1):
        out[n] = (ell + beta) * math.exp(-w * t1)
        beta = (ell + beta) * e
    return out


def sole_distance(model: CaptureModel, point, sole) -> float:
    """Euclidean distance (m, 0 inside) from ``point`` (world x, y) to the sole rectangle at ``sole`` = (x, y, yaw)
    (m, m, rad: its centre and the heading of its x axis)."""
    p = _xy(point, "point")
    x, y, yaw = (float(v) for v in sole)
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = p[0] - x, p[1] - y
    u, v = c * dx + s * dy, -s * dx + c * dy
    return math.hypot(max(abs(u) - 0.5 * model.sole_length, 0.0), max(abs(v) - 0.5 * model.sole_width, 0.0))


@dataclass(frozen=True)
class Capturability:
    """The verdict of :func:`capturability`.

    Attributes:
        steps: the fewest steps N ≤ ``n_max`` that capture the push (0: the CoP alone), or None: none of them.
        icp: (2,) the capture point after the push's jump (m, world).
        shift: (2,) the push's jump Δξ (m).
        distance: m, from ``icp`` to the nearest stance sole (0 inside).
        margins: (n_max + 1,) β'_N (m) the distance is compared with.
    """

    steps: int | None
    icp: np.ndarray
    shift: np.ndarray
    distance: float
    margins: np.ndarray

    @property
    def capturable(self) -> bool:
        return self.steps is not None


def capturability(model: CaptureModel, com, com_velocity, force, duration: float, stance, t_first: float,
                  n_max: int = CAPTURE_STEPS_MAX) -> Capturability:
    """Whether a push at this state is 0-, 1-, …, ``n_max``-step capturable for ``model`` (module docstring).

    Args:
        com: CoM position at the push onset (m, world (2,) or (3,)). com_velocity: its velocity (m/s).
        force: horizontal push force (N, world (2,) or (3,)). duration: s, ≥ 0.
        stance: the soles in contact at the onset, a list of one or two (x, y, yaw) (m, m, rad).
        t_first: s from the onset to the first touch-down a step can make (single support: the swing's time
            left; double support: ``model.swing_time``).
        n_max: most steps tried.

    Returns:
        :class:`Capturability`.

    Raises:
        InvalidInputError: a non-finite or wrongly shaped vector, ``stance`` not one or two (x, y, yaw), a negative
            duration or time.
    """
    c, v = _xy(com, "com"), _xy(com_velocity, "com_velocity")
    soles = [tuple(float(x) for x in np.asarray(s, dtype=float).ravel()) for s in np.atleast_2d(stance)] \
        if len(stance) else []
    if len(soles) not in (1, 2) or any(len(s) != 3 or not all(map(math.isfinite, s)) for s in soles):
        raise InvalidInputError(f"stance must be one or two soles (x, y, yaw) (m, m, rad), got {stance!r}")
    shift = push_capture_shift(model, force, duration)
    icp = c + v / model.omega + shift
    margins = capture_margins(model, t_first, n_max)
    distance = min(sole_distance(model, icp, s) for s in soles)
    inside = distance == 0.0
    if not inside and len(soles) == 2:  # double support: the hull of both soles holds the CoP without a step
        corners = np.vstack([sole_polygon(x, y, yaw, model.sole_length, model.sole_width) for x, y, yaw in soles])
        inside = float(signed_distance(icp[None, :], convex_hull(corners))[0]) >= 0.0
    if inside:
        steps = 0
    else:
        steps = next((n for n in range(1, len(margins)) if distance <= margins[n]), None)
    return Capturability(steps=steps, icp=icp, shift=shift, distance=distance, margins=margins)
