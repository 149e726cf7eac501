r"""Step adjustment from the measured DCM: where the swing foot must land to capture a disturbed walk.

LIPM / DCM (Englsberger, Ott, Albu-Schäffer, IEEE T-RO 31(2), 2015, eqs. 3–6): ``ξ = c + ċ/ω``,
``ξ̇ = ω (ξ − p)``. With the CoP held at the stance foot ``u_0`` for the rest ``τ = T − t`` of the single support,

    ξ(T) = u_0 + (ξ(t) − u_0) e^{ωτ}                                   (Khadiv et al. 2016, eq. 6)

and a gait keeps a nominal **DCM offset** at the end of the step, ``b = ξ(T) − u_1`` (eq. 7), ``u_1`` the next
footstep. The plan being such a gait (its ZMP is constant on the stance foot in single support,
:mod:`wbc.gait.schedule`), the planned landing ``u_1^nom`` and DCM ``ξ_ref`` satisfy the same relation, so
subtracting the two gives the landing point that restores the nominal offset from the measured DCM:

    u_1 = u_1^nom + e^{ωτ} (ξ(t) − ξ_ref(t))                            (1)

Khadiv, Herzog, Moosavian, Righetti, "Step timing adjustment: a step toward generating robust gaits",
Humanoids 2016 (and "Walking control based on step timing adaptation", IEEE T-RO 36(3), 2020) solve a QP over
``u_1``, the offset ``b`` and the step time ``e^{ωT}`` with the landing inside the kinematic reach; with the step
time held (this module adapts location only) and the offset fixed to its nominal value, the QP's solution is (1)
projected onto the reachable set, which for a box is a clip per axis. Griffin, Wiedebach, Bertrand, Leonessa,
Pratt, "Walking stabilization using step timing and location adjustment on the humanoid robot, Atlas", IROS
2017, use the same DCM-based adjustment with a dead band and a reachable region.

Reachable, collision-free set (stance-sole heading frame, ``x`` forward, ``y`` towards the swing side):
``x ∈ [−max_backward, max_forward]``, ``y ∈ [min_width, max_width]`` — ``min_width`` keeps the soles apart
(> sole width: no sole overlap and the swing leg never crosses the stance leg, since the swing path is a
blend between two points on the swing side, :meth:`wbc.gait.WalkPlan.replan`).

**Step timing** (Khadiv 2016 adapt the step time in the same QP): landing after ``τ'`` instead of ``τ`` (the swing
cut short), the DCM at landing is ``u_0 + (ξ − u_0) e^{ωτ'}`` and the nominal offset still holds, so

    u_1 = u_1^nom + e^{ωτ'} (ξ(t) − u_0) − e^{ωτ} (ξ_ref(t) − u_0)                 (2)

which is (1) for ``τ' = τ``. A step that cannot reach the landing (1) — the reach clips it, e.g. a push towards the
stance leg: the swing foot cannot cross — is cut short so that the next step, which can, comes sooner; a step
clipped at its outer reach lands sooner with a DCM that diverged less (``e^{ωτ'} < e^{ωτ}`` in (2)). This is the
trade-off Khadiv et al. (2016; 2020) solve in one QP over location and ``e^{ωT}``
(:class:`wbc.gait.step_timing.StepTimingQP`, which :class:`wbc.sim.walk.WalkScenario` solves per tick of a swing
for the time and, when the time changes, the landing); (2) stays as the landing of a swing lengthened late
(:meth:`StepAdjuster.stretch_samples`).

Dead band (Griffin 2017) on the DCM error: ``d = e^{ωτ} max(0, 1 − δ/‖e‖) e`` with ``e = ξ − ξ_ref``: the DCM
errors of normal walking stay with the CoP feedback of the stabilizer, and the adjustment is continuous in ``e``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from wbc.exceptions import GaitError
from wbc.gait.footsteps import Footstep, feet_overlap

__all__ = ["StepAdjuster", "StretchLimits"]


class StretchLimits(NamedTuple):
    """Bounds of a swing lengthened towards a later landing (:meth:`StepAdjuster.stretch_samples`).

    Attributes:
        max_stretch: longest lengthening (s). stretch_speed: the foot's speed to its landing (m/s) below which no
            lengthening is needed. stretch_min: smallest move of the landing (m) that lengthens a swing. dt: control
            period (s).
    """

    max_stretch: float
    stretch_speed: float
    stretch_min: float
    dt: float


class StepAdjuster:
    """Landing point of the swing foot from the measured DCM (module docstring, eq. 1), clipped to the reach.

    Args:
        omega: LIPM frequency ω (1/s, > 0).
        max_forward, max_backward: reach of the landing point ahead of / behind the stance sole along the stance
            heading (m, ≥ 0).
        min_width, max_width: lateral distance (m) from the stance sole towards the swing side,
            ``0 < min_width < max_width`` (``min_width`` above the sole width keeps the soles apart).
        dead_band: δ (m, ≥ 0) on the DCM error ‖ξ − ξ_ref‖.
        sole_length, sole_width: sole rectangle (m) for the overlap check of turned feet.

    Raises:
        GaitError: non-finite or out-of-range arguments.
    """

    def __init__(self, omega: float, *, max_forward: float, max_backward: float, min_width: float,
                 max_width: float, dead_band: float = 0.03, sole_length: float = 0.2, sole_width: float = 0.1):
        vals = dict(omega=omega, max_forward=max_forward, max_backward=max_backward, min_width=min_width,
                    max_width=max_width, dead_band=dead_band, sole_length=sole_length, sole_width=sole_width)
        for k, v in vals.items():
            if not (isinstance(v, (int, float, np.floating)) and math.isfinite(v) and v >= 0):
                raise GaitError(f"{k} must be a finite number >= 0; got {v!r}")
        if not omega > 0 or not 0 < min_width < max_width or not sole_length > 0 or not sole_width > 0:
            raise GaitError(f"need omega > 0, 0 < min_width < max_width, sole size > 0; got omega={omega}, "
                            f"min_width={min_width}, max_width={max_width}, sole {sole_length} x {sole_width}")
        self.omega = float(omega)
        self.max_forward, self.max_backward = float(max_forward), float(max_backward)
        self.min_width, self.max_width = float(min_width), float(max_width)
        self.dead_band = float(dead_band)
        self.sole_length, self.sole_width = float(sole_length), float(sole_width)

    def correction(self, xi: np.ndarray, xi_ref: np.ndarray, time_left: float, new_time_left: float | None = None,
                   stance_cop: np.ndarray | None = None) -> np.ndarray:
        """Dead-banded landing correction ``d`` (2,) (m, world xy, to add to the nominal landing): eq. 1, or eq. 2
        when the landing is moved to ``new_time_left``, with the DCM error ``ξ − ξ_ref`` shrunk by δ.

        Args:
            xi, xi_ref: (2,) measured and planned DCM (m, world xy). time_left: τ ≥ 0 (s) to the planned landing.
            new_time_left: τ' (s) to the new landing time (eq. 2); None: τ' = τ (eq. 1).
            stance_cop: (2,) u_0, the plan's CoP on the stance foot (m, world xy); needed with ``new_time_left``.
        """
        xi_ref = np.asarray(xi_ref, float)
        e = np.asarray(xi, float) - xi_ref
        n = float(np.linalg.norm(e))
        es = np.zeros(2) if n <= self.dead_band else (1.0 - self.dead_band / n) * e
        g = math.exp(self.omega * max(float(time_left), 0.0))
        if new_time_left is None:
            return g * es
        u0 = np.asarray(stance_cop, float)
        g1 = math.exp(self.omega * max(float(new_time_left), 0.0))
        return g1 * (xi_ref + es - u0) - g * (xi_ref - u0)

    def lateral_offset(self, nominal: Footstep, stance: tuple[float, float, float], correction: np.ndarray) -> float:
        """Unclipped lateral distance (m) of ``nominal`` moved by ``correction`` (2,) from the ``stance`` sole
        ``(x, y, yaw)``, towards the swing side (stance heading frame): below ``min_width`` the landing wanted lies
        inwards of what the legs allow (a push towards the stance side: the swing foot would have to cross)."""
        xs, ys, yaws = (float(v) for v in stance)
        sign = 1.0 if nominal.side == "left" else -1.0
        px = nominal.x + float(correction[0]) - xs
        py = nominal.y + float(correction[1]) - ys
        return sign * (-math.sin(yaws) * px + math.cos(yaws) * py)

    def landing(self, nominal: Footstep, stance: tuple[float, float, float], correction: np.ndarray) -> Footstep:
        """The adjusted footstep: ``nominal`` moved by ``correction`` (2,) (m, world xy), projected onto the
        reachable box around the ``stance`` sole ``(x, y, yaw)`` (module docstring), then pushed outwards until
        the soles do not overlap (turned feet).

        Returns:
            A :class:`~wbc.gait.Footstep` with the side and yaw of ``nominal``.
        """
        xs, ys, yaws = (float(v) for v in stance)
        c, s = math.cos(yaws), math.sin(yaws)
        sign = 1.0 if nominal.side == "left" else -1.0
        px = nominal.x + float(correction[0]) - xs
        py = nominal.y + float(correction[1]) - ys
        fx = c * px + s * py  # stance heading frame
        fy = sign * (-s * px + c * py)  # towards the swing side
        fx = min(max(fx, -self.max_backward), self.max_forward)
        fy = min(max(fy, self.min_width), self.max_width)
        for _ in range(50):
            x, y = xs + c * fx - s * sign * fy, ys + s * fx + c * sign * fy
            if not feet_overlap(np.array([[xs, ys, yaws]]), np.array([[x, y, nominal.yaw]]),
                                self.sole_length, self.sole_width)[0] or fy >= self.max_width:
                break
            fy = min(fy + 0.01, self.max_width)
        return Footstep(nominal.side, x, y, nominal.yaw)

    def stretch_samples(self, limits: StretchLimits, nominal: Footstep, current: Footstep,
                        stance: tuple[float, float, float], correction: np.ndarray, target: Footstep, foot,
                        dcm: tuple[np.ndarray, np.ndarray], time_left: float) -> int:
        """Control samples by which to lengthen the swing in progress (0: none): step timing adaptation towards a
        later landing (Khadiv, Herzog, Moosavian, Righetti 2020, "Walking control based on step timing adaptation",
        IEEE T-RO 36(3): the step duration ``T`` is a decision variable bounded to ``[T_min, T_max]``, here
        ``T_max`` = planned + ``limits.max_stretch``).

        A push late in a swing, towards the swing side, asks for a landing the foot cannot reach in the time left:
        the foot then lands at its nominal place with the DCM beyond the new stance sole, the other foot cannot
        cross to capture it, and two more steps are needed while the DCM diverges. Landing later with the same foot
        captures it in one step when the landing of eq. 2 (``τ' = τ + Δ``, the DCM diverging further from the stance
        CoP ``u_0`` meanwhile) is within the reach.

        None when the ``target`` landing moved by less than ``stretch_min`` from the ``current`` plan's, moved
        inwards of ``min_width`` (that landing needs the other foot: the step is cut short instead) or is within
        ``stretch_speed · τ`` of the ``foot`` (x, y) (m, world). Else ``Δ``: the least multiple of 10 ms up to
        ``max_stretch`` with ``‖u(τ + Δ) − foot‖ ≤ stretch_speed · (τ + Δ)``, or ``max_stretch``.

        Args:
            nominal: the swing's landing before adjustment. stance: the stance sole ``(x, y, yaw)``. correction: the
                DCM correction (2,) (m). dcm: (ξ measured, ξ_ref planned) (2,) (m). time_left: τ (s).
        """
        if math.hypot(target.x - current.x, target.y - current.y) < limits.stretch_min:
            return 0
        if self.lateral_offset(nominal, stance, correction) < self.min_width:
            return 0
        v = limits.stretch_speed
        if math.hypot(target.x - foot[0], target.y - foot[1]) <= v * time_left:
            return 0
        xi, xi_ref = dcm
        u0 = np.array(stance[:2])
        n_max = int(round(limits.max_stretch / limits.dt))
        step = max(1, int(round(0.01 / limits.dt)))
        for n in range(step, n_max + step, step):
            n = min(n, n_max)
            tl = time_left + n * limits.dt
            c2 = self.correction(xi, xi_ref, time_left, tl, u0)
            t2 = self.landing(nominal, stance, c2)
            if math.hypot(t2.x - foot[0], t2.y - foot[1]) <= v * tl:
                return n
        return n_max
