r"""Centre-of-mass plan: exact linear-inverted-pendulum (LIPM) solution for a piecewise-linear ZMP reference.

Model and notation (xy components only; the CoM height ``z_c`` above the flat ground z = 0 is constant):

* LIPM (Kajita et al., IROS 2001):  ``c̈ = ω² (c − p)``,  ``ω = sqrt(g / z_c)``, with ``c`` the CoM and ``p``
  the ZMP.
* Divergent component of motion (DCM; Englsberger, Ott & Albu-Schäffer, "Three-dimensional bipedal walking
  control based on divergent component of motion", IEEE T-RO 31(2), 2015; Takenaka et al., "Real time motion
  generation and control for biped robot, 1st report: walking gait pattern generation", IROS 2009):
  ``ξ = c + ċ/ω``, hence ``ξ̇ = ω (ξ − p)`` (unstable, driven by the ZMP) and ``ċ = ω (ξ − c)`` (stable: the CoM
  follows the DCM).

Segment j of the reference lasts ``T_j`` and is linear in its local time ``τ ∈ [0, T_j]``:
``p(τ) = a_j + s_j τ``, ``s_j = (b_j − a_j) / T_j``. With ``β_j = exp(−ω T_j)``:

1. DCM (particular + homogeneous solution of ``ξ̇ = ω(ξ − p)``):
   ``ξ(τ) = p(τ) + s_j/ω + K_j exp(ω(τ − T_j))``,  ``K_j = ξ_j^end − b_j − s_j/ω``.
2. Backward recursion (Englsberger et al. 2015, recursion of the end-of-step DCMs from the last step back):
   terminal condition ``ξ_{M−1}^end = b_{M−1}`` (at rest over the final ZMP), ``ξ_j^end = ξ_{j+1}^start`` and
   ``ξ_j^start = a_j + s_j/ω + K_j β_j``; in closed form ``ξ_j^start = Σ_{k≥j} e^{−ω(t_k − t_j)} α_k
   + e^{−ω(t_end − t_j)} b_{M−1}`` with ``α_j = a_j + s_j/ω − (b_j + s_j/ω) β_j`` (one matrix product).
3. CoM: ``c(τ) = p(τ) + D_j exp(−ωτ) + (K_j/2) exp(ω(τ − T_j))``. It satisfies ``c̈ = ω²(c − p)`` exactly for
   any ``D_j`` (``p̈ = 0``) and ``c + ċ/ω = ξ``; ``D_j = c_j^start − a_j − (K_j/2) β_j`` with ``c_j^start`` from
   continuity of ``c``: ``c_{j+1}^start = β_j c_j^start + γ_j``, ``γ_j = b_j − β_j a_j + K_j (1 − β_j²)/2``.
   ``ċ`` is then continuous too (``ċ = ω(ξ − c)`` and both are continuous).
4. Initial condition: the plan must start at the measured CoM ``c_0`` and velocity ``ċ_0``, i.e.
   ``ξ_0^start = c_0 + ċ_0/ω``. The first segment's start point ``a_0`` is free (a double-support shift, or the
   remainder of the current phase when replanning), and ``ξ_0^start`` is affine in it::

       ξ_0^start = a_0 (1 − (1 − β_0)/(ω T_0)) + b_0 ((1 − β_0)/(ω T_0) − β_0) + β_0 ξ_0^end

   so ``a_0`` is solved exactly (the coefficient lies in (0, 1) for ``T_0 > 0``). The caller checks that
   ``a_0`` lies in the current support polygon.

Derivatives are analytic: ``ċ = s_j − ω D_j e^{−ωτ} + (ω K_j/2) e^{ω(τ−T_j)}``,
``c̈ = ω² (D_j e^{−ωτ} + (K_j/2) e^{ω(τ−T_j)})``. Exponentials are written so that their arguments are ≤ 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from wbc.constants import GRAVITY

__all__ = ["lipm_omega", "LipmPlan", "LipmSamples", "plan_lipm"]


def lipm_omega(com_height: float, gravity: float = GRAVITY) -> float:
    """Natural frequency ``ω = sqrt(g / z_c)`` (1/s) of the LIPM for a CoM height ``z_c`` (m) above the ground."""
    return math.sqrt(gravity / com_height)


@dataclass(frozen=True)
class LipmSamples:
    """LIPM trajectories on the sample grid, world frame.

    The arrays are column views of one (N, 13) buffer: every row is contiguous, the 2-D arrays are not.

    Attributes:
        com (m), com_vel (m/s), com_acc (m/s²): (N, 3) CoM and its analytic derivatives; z is the constant
            height (zero velocity and acceleration).
        zmp: (N, 2) ZMP reference (m).
        dcm: (N, 2) divergent component of motion ``c + ċ/ω`` (m).
    """

    com: np.ndarray
    com_vel: np.ndarray
    com_acc: np.ndarray
    zmp: np.ndarray
    dcm: np.ndarray


@dataclass(frozen=True)
class LipmPlan:
    """Coefficients of the exact LIPM solution per ZMP segment (see the module docstring).

    Attributes:
        omega: LIPM frequency (1/s).
        dt: sample period (s).
        first, count: (M,) int, first sample and sample count of each segment.
        start, end: (M, 2) ZMP at segment start / end (m); ``start[0]`` is the solved free start point.
        K, D: (M, 2) coefficients of the unstable / stable exponentials (m).
    """

    omega: float
    dt: float
    first: np.ndarray
    count: np.ndarray
    start: np.ndarray
    end: np.ndarray
    K: np.ndarray
    D: np.ndarray

    @property
    def n_samples(self) -> int:
        """Number of samples ``N = sum(count) + 1`` (the last one ends the last segment)."""
        return int(self.count.sum()) + 1

    def sample(self, height: float = 0.0) -> LipmSamples:
        """Evaluate the plan at every sample ``k * dt``, ``k = 0 .. N-1``; ``height`` (m) fills ``com[:, 2]``.

        Every output is linear in the basis ``(1, τ, e^{−ωτ}, e^{ω(τ−T_j)})`` of its segment: the basis is
        computed for all samples at once, then one (n_j, 4) @ (4, 13) product per segment gives all outputs.
        """
        m, w, dt = self.first.shape[0], self.omega, self.dt
        n = int(self.count.sum()) + 1
        reps = self.count.copy()
        reps[-1] += 1  # the final sample closes the last segment
        dur = self.count * dt
        tau = (np.arange(n) - np.repeat(self.first, reps)) * dt
        basis = np.empty((4, n))
        basis[0] = 1.0
        basis[1] = tau
        np.exp(-w * tau, out=basis[2])
        np.exp(w * (tau - np.repeat(dur, reps)), out=basis[3])

        slope = (self.end - self.start) / dur[:, None]
        V = np.concatenate((self.start, slope, self.D, self.K, np.ones((m, 1))), axis=1)  # (M, 9)
        C = (V @ _output_map(w, float(height))).reshape(m, 4, 13)
        out = np.empty((n, 13))
        bt = basis.T
        bounds = np.append(self.first, n).tolist()
        for j in range(m):
            np.matmul(bt[bounds[j]:bounds[j + 1]], C[j], out=out[bounds[j]:bounds[j + 1]])
        return LipmSamples(out[:, 0:3], out[:, 3:6], out[:, 6:9], out[:, 9:11], out[:, 11:13])


@lru_cache(maxsize=32)
def _output_map(w: float, height: float) -> np.ndarray:
    """(9, 52) linear map from a segment's ``(a, s, D, K, 1)`` to the (4, 13) coefficients of
    ``(1, τ, e^{−ωτ}, e^{ω(τ−T)})`` for the outputs ``(com xyz, vel xyz, acc xyz, zmp xy, dcm xy)``.
    Cached, read-only."""
    W = np.zeros((9, 4, 13))
    for i in range(2):
        a, s, d, k = i, 2 + i, 4 + i, 6 + i
        W[a, 0, i] = W[a, 0, 9 + i] = W[a, 0, 11 + i] = 1.0  # com, zmp, dcm: a
        W[s, 0, 3 + i] = 1.0  # vel: s
        W[s, 0, 11 + i] = 1.0 / w  # dcm: s / w
        W[s, 1, i] = W[s, 1, 9 + i] = W[s, 1, 11 + i] = 1.0  # com, zmp, dcm: s * tau
        W[d, 2, i], W[d, 2, 3 + i], W[d, 2, 6 + i] = 1.0, -w, w * w  # D e^{-w tau} and derivatives
        W[k, 3, i], W[k, 3, 3 + i], W[k, 3, 6 + i] = 0.5, 0.5 * w, 0.5 * w * w  # (K/2) e^{w(tau-T)} ...
        W[k, 3, 11 + i] = 1.0  # dcm: K e^{w(tau-T)}
    W[8, 0, 2] = height
    W = W.reshape(9, 52)
    W.flags.writeable = False
    return W


def plan_lipm(first: np.ndarray, count: np.ndarray, zmp_start: np.ndarray, zmp_end: np.ndarray,
              com_xy: np.ndarray, com_vel_xy: np.ndarray, omega: float, dt: float) -> LipmPlan:
    """Solve the LIPM for a piecewise-linear ZMP reference, starting exactly at a given CoM state.

    Args:
        first, count: (M,) int, first sample and number of samples (>= 1) of each ZMP segment, contiguous from 0.
        zmp_start, zmp_end: (M, 2) ZMP at each segment's start / end (m, world xy); ``zmp_start[0]`` is ignored
            (solved, see step 4 of the module docstring); ``zmp_start[j+1]`` should equal ``zmp_end[j]``.
        com_xy, com_vel_xy: (2,) initial CoM position (m) and velocity (m/s).
        omega: LIPM frequency (1/s), see :func:`lipm_omega`.
        dt: sample period (s).

    Returns:
        A :class:`LipmPlan` ending at rest (DCM on ``zmp_end[-1]``); its ``start[0]`` is the ZMP start point
        that realises the initial state.

    Source: Englsberger, Ott, Albu-Schäffer, IEEE T-RO 31(2), 2015 (DCM dynamics and backward recursion);
    Takenaka et al., IROS 2009. Inputs are assumed validated by the caller.
    """
    w = float(omega)
    first = np.asarray(first)
    count = np.asarray(count)
    a = np.array(zmp_start, dtype=float)
    b = np.asarray(zmp_end, dtype=float)
    T = count * dt
    t0 = first * dt
    t_end = t0[-1] + T[-1]
    beta = np.exp(-w * T)

    # Backward DCM recursion over segments 1..M-1 (their start points are fixed).
    sig = (b[1:] - a[1:]) / (w * T[1:, None])
    alpha = a[1:] + sig - (b[1:] + sig) * beta[1:, None]
    dk = first[None, 1:] - first[1:, None]  # (M-1, M-1): samples from t_j to t_k (integers: exact test)
    E = np.where(dk >= 0, np.exp(-w * dt * np.maximum(dk, 0)), 0.0)
    xi_start_rest = E @ alpha + np.exp(-w * (t_end - t0[1:]))[:, None] * b[-1]
    xi_end0 = xi_start_rest[0] if a.shape[0] > 1 else b[-1]

    # Initial condition: solve the first segment's free start point.
    xi0 = np.asarray(com_xy, dtype=float) + np.asarray(com_vel_xy, dtype=float) / w
    q = (1.0 - beta[0]) / (w * T[0])
    a[0] = (xi0 - b[0] * (q - beta[0]) - beta[0] * xi_end0) / (1.0 - q)

    xi_end = np.vstack([xi_start_rest, b[-1:]])  # (M, 2): xi_j^end = xi_{j+1}^start, last = b_{M-1}
    K = xi_end - b - (b - a) / (w * T[:, None])

    # Forward CoM continuity: c_{j+1}^start = beta_j c_j^start + gamma_j.
    gamma = b - beta[:, None] * a + 0.5 * K * (1.0 - beta[:, None] ** 2)
    dc = first[:, None] - (first + count)[None, :]  # (M, M): samples from t_{k+1} to t_j
    L = np.where(dc >= 0, np.exp(-w * dt * np.maximum(dc, 0)), 0.0)
    c_start = np.exp(-w * (t0 - t0[0]))[:, None] * np.asarray(com_xy, dtype=float) + L @ gamma
    D = c_start - a - 0.5 * K * beta[:, None]
    return LipmPlan(w, float(dt), first, count, a, b, K, D)
