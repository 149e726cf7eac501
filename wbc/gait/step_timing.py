r"""Step location and timing from one small QP on the DCM, per control tick of a single support.

Khadiv, Herzog, Moosavian, Righetti, "Walking control based on step timing adaptation", IEEE T-RO 36(3), 2020
(and "Step timing adjustment: a step toward generating robust gaits", Humanoids 2016). LIPM / DCM with the CoP held
at the stance foot ``u_0`` during the single support of duration ``T`` (Englsberger et al. 2015, eq. 6):
``ξ(T) = u_0 + (ξ(t) − u_0) e^{ω(T − t)}``, ``t`` the time since the step began. With the **DCM offset**
``b = ξ(T) − u_T`` (``u_T`` the next footstep) and the step time changed into ``τ = e^{ωT}``, the DCM at
touch-down is linear in the variables ``x = (u_T, τ, b) ∈ R^5``:

    (K1)  u_T + b − (ξ(t) − u_0) e^{−ωt} τ = u_0                               (2 equalities)

    (K2)  minimise  α_u ‖u_T − u_nom‖² + α_τ (τ − τ_nom)² + α_b ‖b − b_nom‖²

    (K3)  subject to  R_sᵀ (u_T − s) ∈ [−l_back, l_fwd] × σ [w_min, w_max]          (reach, stance heading frame)

    (K4)              e^{ωT_min} ≤ τ ≤ e^{ωT_max}

(K1)–(K4) are the paper's QP — a viable state kept viable by the next step's location and time alone, with the
step time as ``τ = e^{ωT}`` so that the constraint is linear (the labels K1–K4 are this module's, not the paper's
equation numbers) — here with the reach in the stance sole's heading frame ``R_s``, ``s`` the stance sole,
``σ = ±1`` towards the swing side: ``w_min`` > 0 keeps the swing foot from crossing the stance leg. The nominal
values come from the walk's plan: ``u_nom`` its footstep, ``τ_nom = e^{ωT_nom}``, and ``b_nom`` the offset of its
DCM ``ξ_ref(t)`` (``b_nom = u_0 + (ξ_ref(t) − u_0) e^{ω(T_nom − t)} − u_nom``), so that ``ξ(t) = ξ_ref(t)`` gives
the nominal step back (eq. 1 of :mod:`wbc.gait.step_adjustment` is (K1) with ``τ = τ_nom``, ``b = b_nom``).
``T_min`` is where the caller puts what the swing can do: its foot must still travel to ``u_T`` at a speed the leg's
joints can follow (:meth:`StepTimingQP.solve` ``t_min``). The weights make timing the second means of capture: a
change of ``τ`` costs ``α_τ`` per unit (``dτ/dT = ωτ``: 0.06 s ≈ 1 at Talos's ``ω``, ``T``), so the QP moves the
landing first and changes the step time once the reach (K3) stops the landing.

Solved by DAQP (Arnström, Bemporad, Axehill, "A dual active-set solver for embedded quadratic programming using
recursive LDLᵀ updates", IEEE TAC 67(8), 2022), the library of the controller's own QPs: 5 variables, 2 equalities,
2 two-sided reach rows, 1 bounded variable.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from wbc.exceptions import GaitError

__all__ = ["StepTiming", "StepTimingQP", "STEP_TIMING_WEIGHTS"]

#: (α_u, α_τ, α_b) of (K2) (module docstring): landing 1 per m², ``τ`` 5 per unit², DCM offset 1000 per m². Chosen
#: here, not taken from the paper: the offset held nearly at its nominal value, so that with the time held the
#: landing is eq. 1 of :mod:`wbc.gait.step_adjustment` clipped to the reach (to 0.1 %); α_τ = 1 cut the pushed
#: walk of ``tests/sim/test_walk.py`` (towards the stance leg) into QP failures of the controller (10 ticks), 5 did
#: not (benchmarks/records/41-step-timing-qp.md).
STEP_TIMING_WEIGHTS = (1.0, 5.0, 1000.0)

_INF = 1e30  # DAQP's "no bound"


class StepTiming(NamedTuple):
    """Solution of :class:`StepTimingQP` (module docstring, (K1)–(K4)).

    Attributes:
        landing: (2,) next footstep ``u_T`` (m, world xy). duration: step time ``T`` (s, from the step's start).
        offset: (2,) DCM offset ``b = ξ(T) − u_T`` (m, world xy). tau: ``e^{ωT}``.
    """

    landing: np.ndarray
    duration: float
    offset: np.ndarray
    tau: float


class StepTimingQP:
    """The next step's landing and time from the measured DCM (module docstring): one QP of 5 variables.

    Args:
        omega: LIPM frequency ω (1/s, > 0).
        max_forward, max_backward: reach of the landing ahead of / behind the stance sole along its heading (m, ≥ 0).
        min_width, max_width: lateral distance (m) from the stance sole towards the swing side,
            ``0 < min_width < max_width``.
        weights: (α_u, α_τ, α_b) of (K2), each > 0 (default :data:`STEP_TIMING_WEIGHTS`).

    Raises:
        GaitError: non-finite or out-of-range arguments.
    """

    def __init__(self, omega: float, *, max_forward: float, max_backward: float, min_width: float,
                 max_width: float, weights: tuple[float, float, float] = STEP_TIMING_WEIGHTS):
        vals = dict(omega=omega, max_forward=max_forward, max_backward=max_backward, min_width=min_width,
                    max_width=max_width)
        for k, v in vals.items():
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating)) or not math.isfinite(v) or v < 0:
                raise GaitError(f"{k} must be a finite number >= 0; got {v!r}")
        w = np.asarray(weights, dtype=float)
        if w.shape != (3,) or not np.all(np.isfinite(w)) or not np.all(w > 0):
            raise GaitError(f"weights must be three finite numbers > 0 (α_u, α_τ, α_b); got {weights!r}")
        if not omega > 0 or not 0 < min_width < max_width:
            raise GaitError(f"need omega > 0 and 0 < min_width < max_width; got omega={omega}, "
                            f"min_width={min_width}, max_width={max_width}")
        self.omega = float(omega)
        self.max_forward, self.max_backward = float(max_forward), float(max_backward)
        self.min_width, self.max_width = float(min_width), float(max_width)
        self.weights = (float(w[0]), float(w[1]), float(w[2]))
        au, at, ab = self.weights
        self._H = np.diag([au, au, at, ab, ab])  # DAQP: ½ xᵀHx + fᵀx  ⇔  (K2) halved
        self._A = np.zeros((4, 5))
        self._A[2:, :2] = np.eye(2)
        self._A[2:, 3:] = np.eye(2)
        self._upper = np.full(9, _INF)
        self._lower = np.full(9, -_INF)
        self._sense = np.zeros(9, dtype=np.int32)
        self._sense[7:] = 5  # (K1): equalities

    def solve(self, xi: np.ndarray, *, stance: tuple[float, float, float], stance_cop: np.ndarray, swing_left: bool,
              elapsed: float, landing_nom: np.ndarray, duration_nom: float, offset_nom: np.ndarray,
              t_min: float, t_max: float) -> StepTiming:
        """Solve (K1)–(K4) for the measured DCM ``xi``.

        Args:
            xi: (2,) DCM (m, world xy) at ``elapsed``. stance: the stance sole ``(x, y, yaw)`` (m, m, rad, world).
            stance_cop: (2,) ``u_0``, the CoP held on the stance foot (m, world xy). swing_left: the swing foot is
                the left one (the reach's lateral side). elapsed: ``t`` ≥ 0, time since the step began (s).
            landing_nom: (2,) ``u_nom`` (m, world xy). duration_nom: ``T_nom`` (s). offset_nom: (2,) ``b_nom`` (m).
            t_min, t_max: bounds of ``T`` (s), ``elapsed ≤ t_min ≤ t_max``.

        Returns:
            :class:`StepTiming`.

        Raises:
            GaitError: non-finite input, bad bounds, or the QP not solved (DAQP's exit flag).
        """
        import daqp

        w = self.omega
        xi = np.asarray(xi, dtype=float)
        u0 = np.asarray(stance_cop, dtype=float)
        un = np.asarray(landing_nom, dtype=float)
        bn = np.asarray(offset_nom, dtype=float)
        for name, a in (("xi", xi), ("stance_cop", u0), ("landing_nom", un), ("offset_nom", bn)):
            if a.shape != (2,) or not np.all(np.isfinite(a)):
                raise GaitError(f"{name} must be a finite (2,) array; got {a!r}")
        sx, sy, syaw = (float(v) for v in stance)
        scalars = (sx, sy, syaw, elapsed, duration_nom, t_min, t_max)
        if not all(math.isfinite(float(v)) for v in scalars):
            raise GaitError(f"stance, elapsed, duration_nom, t_min, t_max must be finite; got {scalars!r}")
        if not 0.0 <= elapsed <= t_min <= t_max or not duration_nom > 0:
            raise GaitError(f"need 0 <= elapsed <= t_min <= t_max and duration_nom > 0; got elapsed={elapsed}, "
                            f"t_min={t_min}, t_max={t_max}, duration_nom={duration_nom}")
        au, at, ab = self.weights
        tau_nom = math.exp(w * duration_nom)
        f = -np.array([au * un[0], au * un[1], at * tau_nom, ab * bn[0], ab * bn[1]])
        c, s = math.cos(syaw), math.sin(syaw)
        sign = 1.0 if swing_left else -1.0
        A, up, lo = self._A.copy(), self._upper.copy(), self._lower.copy()
        A[0, :2] = (c, s)  # along the stance heading
        A[1, :2] = (-sign * s, sign * c)  # towards the swing side
        fx, fy = c * sx + s * sy, -sign * s * sx + sign * c * sy
        lo[5], up[5] = fx - self.max_backward, fx + self.max_forward
        lo[6], up[6] = fy + self.min_width, fy + self.max_width
        g = (xi - u0) * math.exp(-w * elapsed)
        A[2:, 2] = -g
        lo[7:] = up[7:] = u0
        lo[2], up[2] = math.exp(w * t_min), math.exp(w * t_max)
        x, _, flag, _ = daqp.solve(self._H, f, A, up, lo, self._sense)
        if flag < 1 or not np.all(np.isfinite(x)):
            raise GaitError(f"step timing QP not solved (DAQP exit flag {flag})")
        tau = float(min(max(x[2], lo[2]), up[2]))
        return StepTiming(np.array(x[:2]), math.log(tau) / w, np.array(x[3:]), tau)

    def nominal_offset(self, xi_ref: np.ndarray, stance_cop: np.ndarray, landing_nom: np.ndarray,
                       time_left: float) -> np.ndarray:
        """``b_nom`` (2,) (m): the plan's DCM offset at its touch-down, ``u_0 + (ξ_ref − u_0) e^{ωτ} − u_nom``
        (module docstring), ``xi_ref`` the plan's DCM now, ``time_left`` τ ≥ 0 (s) to the planned touch-down."""
        u0 = np.asarray(stance_cop, dtype=float)
        return u0 + (np.asarray(xi_ref, dtype=float) - u0) * math.exp(self.omega * max(float(time_left), 0.0)) \
            - np.asarray(landing_nom, dtype=float)
