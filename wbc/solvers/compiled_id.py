"""The compiled exact solver of the inverse-dynamics QP (:class:`CompiledIDSolver`), the first rung of the ID
formulation's :class:`~wbc.solvers.fallback.FallbackChain` (``solver="fast"``), warm-started from its last working
set. The QP is that of :mod:`wbc.formulations.acceleration`: H = blockdiag(H_vv, ε_f I) over x = [v̇; f].

First the block equality step (:func:`_equality_step`): the bounds of the previous tick's working set are held, and
the equality-constrained QP over the free variables (F: accelerations, f: forces, X: held) is solved by the
range-space method (Nocedal & Wright 2006, *Numerical Optimization*, §16.2, eq. 16.16):

    L Lᵀ = H_FF,  t = L⁻¹ (g_F + H_FX x_X),  Y = L⁻¹ A_Fᵀ,  S = Yᵀ Y + A_f D⁻¹ A_fᵀ  (D = ε_f I on the free forces),
    S ν = −(b − A_X x_X + A_f D⁻¹ g_f + Yᵀ t),   x_F = −L⁻ᵀ (t + Y ν),   x_f = −D⁻¹ (g_f + A_fᵀ ν).

If x meets every bound and row (to 1e-12) and every held bound's multiplier λ_i = −σ_i (H x + g + Aᵀν)_i ≥ 0 (σ_i =
−1 at lb, +1 at ub), x is the optimum of the full QP. When one bound explains the failure it enters (or leaves) the
working set and the step runs once more; otherwise the Goldfarb–Idnani dual active set
(:func:`~wbc.solvers.active_set.dual_active_set` on a :class:`~wbc.solvers.active_set.BlockSpace`) takes over. The
answer matches quadprog's on the same QP to ≈ 1e-11 (less along directions held by ε_a alone, κ(H_vv) ~ 1e8);
closed-loop trajectories of two exact solvers still part, so solvers are compared tick by tick
(``tests/formulations/test_idkernel.py``).
"""

from __future__ import annotations

from collections import namedtuple

import numba as nb
import numpy as np

from wbc.compiled import CHECK_TYPES, FASTMATH, specialise
from wbc.exceptions import SolverError
from wbc.solvers.active_set import ActiveSetArrays, ActiveSetSettings, BlockSpace, dual_active_set
from wbc.solvers.linalg import (backward_substitution, block_cost_gradient, carve, carve2, cholesky_lower,
                                clip_eq_residual, forward_substitution, primal_from_multipliers)
from wbc.solvers.qp_data import QPData, QPSolution
from wbc.solvers.status import SolverStatus

__all__ = ["CompiledIDSolver", "EqualityStepSpace", "IDSolveBuffers", "KERNEL_ITERATION_COST",
           "KERNEL_ITERATIONS_AFTER_GIVE_UP", "id_solve", "kernel_iterations"]

#: the buffers of :func:`id_solve` (:func:`id_solve_buffers`)
IDSolveBuffers = namedtuple("IDSolveBuffers", "ws_s ws_f ws_i ws_b out")
#: workspace of :func:`_equality_step` (module docstring's names): nv; L (nv, nv); Yt (≥ m, nv) = Yᵀ; S (≥ m, ≥ m);
#: t (nv,); dinv (n,) D⁻¹ (0 on held forces); fnz (≥ m,) bool rows with a free force; vfree (nv,) int64 the free
#: accelerations; xv (≥ nv,), bx (≥ m,) scratch
EqualityStepSpace = namedtuple("EqualityStepSpace", "nv L Yt S t dinv fnz vfree xv bx")

#: squared sine (in the H⁻¹ metric) between a constraint and the span of the working set below which it counts as
#: dependent on it (the ID tick's :func:`~wbc.solvers.active_set.dual_active_set`)
DEPENDENCE_TOL = 1e-10
#: violation (constraint units: m/s², N, N·m) beyond which a bound or row enters the working set (the same solve)
PRIMAL_TOL = 1e-11
#: largest constraint violation (m/s², N, N·m) of the solve's final KKT check (the same solve)
VERIFY_TOL = 1e-9

#: CPU time (s) of one working-set iteration of :func:`id_solve` with its share of the set-up
#: (benchmarks/README.md, "ID kernel cap from its measured iteration cost"; :func:`kernel_iterations`)
KERNEL_ITERATION_COST = 1.2e-4

#: iteration cap on the tick after a call that gave up: it starts from the next rung's answer, one change away
KERNEL_ITERATIONS_AFTER_GIVE_UP = 2

_STATUS_CODES = {int(code) for code in SolverStatus}


def kernel_iterations(budget: float) -> int:
    """Iteration cap of :class:`CompiledIDSolver` for a tick budget of ``budget`` s of CPU time: a quarter of the
    budget at :data:`KERNEL_ITERATION_COST` per iteration, between 4 and 100 (100: unbounded). A count, not a clock."""
    if not np.isfinite(budget):
        return 100
    return int(min(100, max(4, budget / (4.0 * KERNEL_ITERATION_COST))))


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def _equality_step(qp, state, rstate, x, nu, es, tol):
    """The equality step of the module docstring for the working set ``state`` of ``qp`` (H, g, A, b, m, C, l, u,
    lb, ub) in the workspace ``es``, x (n,) and ν (≥ m,) written into x and nu (forces with lb = ub held too).
    Returns (residual, i, side): the largest equality residual, or −1 when x is not the optimum or the step does not
    apply (a working row, a joint with lb = ub, H_FF or S not positive definite, a violation above ``tol``, a
    negative held multiplier); then (i, side) the one change it points to — the most violated free variable (side
    ∓1: held at lb/ub), else the held bound with the most negative multiplier (side 0: released) — or i = −1."""
    H, g, A, b, m, C, l, u, lb, ub = qp
    nv, L, Yt, S, t, dinv, fnz, vfree, xv, bx = es
    n = H.shape[0]
    for r in range(rstate.size):
        if rstate[r] != 0:
            return -1.0, -1, 0
    nfv = 0
    for i in range(nv):
        if lb[i] == ub[i]:
            return -1.0, -1, 0
        s = state[i]
        if s == 0:
            vfree[nfv] = i
            nfv += 1
        else:
            bound = lb[i] if s < 0 else ub[i]
            if not np.isfinite(bound):
                return -1.0, -1, 0
            x[i] = bound
    for f in range(nv, n):
        if lb[f] == ub[f] or state[f] != 0:
            bound = ub[f] if (state[f] > 0 and lb[f] != ub[f]) else lb[f]
            if not np.isfinite(bound):
                return -1.0, -1, 0
            x[f] = bound
            dinv[f] = 0.0
        else:
            dinv[f] = 1.0 / H[f, f]
    held = nfv < nv
    for a in range(nfv):
        i = vfree[a]
        s = g[i]
        if held:
            for j in range(nv):
                if state[j] != 0:
                    s += H[i, j] * x[j]
        t[a] = s
        for c in range(a + 1):
            L[a, c] = H[i, vfree[c]]
    if not cholesky_lower(L, nfv):
        return -1.0, -1, 0
    forward_substitution(L, nfv, t)
    for k in range(m):
        Ak = A[k]
        y = Yt[k]
        for a in range(nfv):
            y[a] = Ak[vfree[a]]
        acc = b[k]
        if held:
            for j in range(nv):
                if state[j] != 0:
                    acc -= Ak[j] * x[j]
        nz = False
        for f in range(nv, n):
            if dinv[f] == 0.0:
                acc -= Ak[f] * x[f]
            elif Ak[f] != 0.0:
                nz = True
                acc += Ak[f] * g[f] * dinv[f]
        fnz[k] = nz
        bx[k] = acc
    # Y = L⁻¹ A_Fᵀ: the m forward substitutions together, row i of L once for every k (measured 2× faster than
    # one substitution per row)
    for i in range(nfv):
        d = 1.0 / L[i, i]
        for k in range(m):
            acc = Yt[k, i]
            for p in range(i):
                acc -= L[i, p] * Yt[k, p]
            Yt[k, i] = acc * d
    for k in range(m):
        Ak = A[k]
        Yk = Yt[k]
        for c in range(k + 1):
            Yc = Yt[c]
            acc = 0.0
            for a in range(nfv):
                acc += Yk[a] * Yc[a]
            if fnz[k] and fnz[c]:
                Ac = A[c]
                for f in range(nv, n):
                    acc += Ak[f] * Ac[f] * dinv[f]
            S[k, c] = acc
        acc = bx[k]
        for a in range(nfv):
            acc += Yk[a] * t[a]
        nu[k] = -acc
    if not cholesky_lower(S, m):
        return -1.0, -1, 0
    forward_substitution(S, m, nu)
    backward_substitution(S, m, nu)
    primal_from_multipliers(L, nfv, t, Yt, nu, m, xv)
    for a in range(nfv):
        x[vfree[a]] = xv[a]
    for f in range(nv, n):
        if dinv[f] != 0.0:
            s = g[f]
            for k in range(m):
                if fnz[k]:
                    s += A[k, f] * nu[k]
            x[f] = -s * dinv[f]
    # primal feasibility of the free variables and of every row
    worst = tol
    wi = -1
    ws = 0
    for i in range(n):
        if state[i] == 0 and lb[i] != ub[i]:
            if lb[i] - x[i] > worst:
                worst, wi, ws = lb[i] - x[i], i, -1
            elif x[i] - ub[i] > worst:
                worst, wi, ws = x[i] - ub[i], i, 1
    if wi >= 0:
        return -1.0, wi, ws
    for r in range(C.shape[0]):
        acc = 0.0
        Cr = C[r]
        for j in range(n):
            acc += Cr[j] * x[j]
        if acc < l[r] - tol or acc > u[r] + tol:
            return -1.0, -1, 0
    # dual feasibility of the held bounds
    worst = 0.0
    wi = -1
    for i in range(n):
        if state[i] == 0 or lb[i] == ub[i]:
            continue
        s = block_cost_gradient(H, g, x, i, nv)
        for k in range(m):
            s += A[k, i] * nu[k]
        if -state[i] * s < worst:
            worst, wi = -state[i] * s, i
    if wi >= 0:
        return -1.0, wi, 0
    return clip_eq_residual(x, lb, ub, A, b, n, m), -1, 0


def id_solve_buffers(n: int, nv: int, p: int, me: int) -> tuple[np.ndarray, ...]:
    """The five zeroed flat buffers of :func:`id_solve` (:data:`IDSolveBuffers`, carved by :func:`carve_solve`) for
    n variables, nv accelerations, p inequality rows and up to ``me`` equality rows: ``ws_s`` int8 (n + p,) the
    working set (state, rstate); ``ws_f`` float64, ``ws_i`` int64, ``ws_b`` bool (me + p,) workspace (ν, μ at the
    end of ws_f); ``out`` float64 (1 + n,) the residual, then x."""
    w = me + p
    nf = w * nv + w * w + nv * nv + nv + 4 * w + 7 * n + p + 3 + me + p
    return (np.zeros(n + p, np.int8), np.zeros(nf), np.zeros(w + nv + max(n - nv, 1) + 3, np.int64),
            np.zeros(w, np.bool_), np.zeros(1 + n))


@nb.njit(cache=True, nogil=True, inline="always")
def carve_solve(ws_s, wf, wi, wb, out, n, nv, p):
    """Disjoint views of :func:`id_solve_buffers`: state, rstate, residual, x, nu, mu and the workspace tuple."""
    w = wb.shape[0]
    state = ws_s[0:n]
    rstate = ws_s[n:n + p]
    residual = out[0:1]
    x = out[1:1 + n]
    Yv, o = carve2(wf, 0, w, nv)
    S, o = carve2(wf, o, w, w)
    L, o = carve2(wf, o, nv, nv)
    tv, o = carve(wf, o, nv)
    rows_w, o = carve2(wf, o, 2, w)  # c, nuw
    c, nuw = rows_w[0], rows_w[1]
    rows_n, o = carve2(wf, o, 5, n)  # a, z, npv, rb, lam_b
    a, z, npv, rb, lam_b = rows_n[0], rows_n[1], rows_n[2], rows_n[3], rows_n[4]
    lam_r, o = carve(wf, o, p)
    ra, o = carve(wf, o, n)
    rc, o = carve(wf, o, w)
    dx, o = carve(wf, o, n)
    drho, o = carve(wf, o, w)
    wout, o = carve(wf, o, 3)
    nu, o = carve(wf, o, w - p)  # the equality rows' multipliers
    mu, o = carve(wf, o, p)
    nff = wi.shape[0] - w - nv - 3
    rows = wi[0:w]
    vfree = wi[w:w + nv]
    ffree = wi[w + nv:w + nv + nff]
    fac = wi[w + nv + nff:w + nv + nff + 3]
    return (state, rstate, residual, x, nu, mu,
            (rows, Yv, S, L, tv, c, nuw, wb, vfree, ffree, fac, a, z, npv, rb, lam_b, lam_r, ra, rc, dx, drho, wout))


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def id_solve(qp, nv, max_iter, buffers):
    """The exact optimum of the ID QP ``qp`` (H, g, A, b, C, l, u, lb, ub) into ``buffers`` (:data:`IDSolveBuffers`:
    x, the residual, the working set read as warm start and written), by the module docstring's steps, the dual
    active set capped at ``max_iter`` iterations (a second equality step only when ``max_iter`` ≥ 2). Returns the
    iterations (1, 2: equality steps) or a negative :class:`~wbc.solvers.status.SolverStatus` code."""
    H, g, A, b, C, l, u, lb, ub = qp
    ws_s, ws_f, ws_i, ws_b, out = buffers
    m = A.shape[0]
    state, rstate, residual, x, nu, mu, ws = carve_solve(ws_s, ws_f, ws_i, ws_b, out, H.shape[0], nv, C.shape[0])
    (ws_rows, ws_Yv, ws_S, ws_L, ws_tv, ws_c, ws_nuw, ws_vrow, ws_vfree, ws_ffree, ws_fac, ws_a, ws_z, ws_npv, ws_rb,
     ws_lam_b, ws_lam_r, ws_ra, ws_rc, ws_dx, ws_drho, ws_out) = ws
    qpm = (H, g, A, b, m, C, l, u, lb, ub)
    step = EqualityStepSpace(nv, ws_L, ws_Yv, ws_S, ws_tv, ws_rb, ws_vrow, ws_vfree, ws_dx, ws_rc)
    res, i, side = _equality_step(qpm, state, rstate, x, nu, step, 1e-12)
    it = 1
    if res < 0.0 and i >= 0 and max_iter >= 2:
        held = state[i]
        state[i] = side
        res = _equality_step(qpm, state, rstate, x, nu, step, 1e-12)[0]
        it = 2
        if res < 0.0:
            state[i] = held  # the general solve starts from the previous tick's working set
    if res >= 0.0:
        residual[0] = res
    else:
        space = BlockSpace(nv, ws_rows, ws_Yv, ws_S, ws_L, ws_vfree, ws_ffree, ws_vrow, ws_fac, ws_a, ws_c, ws_tv,
                           ws_ra, ws_rc, ws_dx, ws_drho, ws_npv, ws_nuw, DEPENDENCE_TOL)
        it = dual_active_set(qpm, space, ActiveSetArrays(state, rstate, x, nu, mu, ws_lam_b, ws_lam_r, ws_z, ws_rb,
                                                         ws_out),
                             ActiveSetSettings(max_iter, PRIMAL_TOL, 0.0, DEPENDENCE_TOL, 0.0, True, True, 1,
                                               VERIFY_TOL))
        residual[0] = ws_out[0]
    return it


class CompiledIDSolver:
    """:func:`id_solve` behind the solver protocol: ``solve(QPData) → QPSolution``.

    Args:
        n, nv, p: variables, accelerations (the dense block), inequality rows. me: the most equality rows a QP has.

    Attributes:
        state, rstate: (n,), (p,) the working set (bounds, inequality rows: −1 lower, +1 upper, 0 free).
        max_iterations: the iteration cap (:func:`kernel_iterations`; :data:`KERNEL_ITERATIONS_AFTER_GIVE_UP` after
            a call that gave up). tolerance: the largest constraint violation of an answer (the chain's backend's).
        solves, fallbacks: calls that answered, and that did not (the chain's next rung answered).
    """

    name = "kernel"

    def __init__(self, n: int, nv: int, p: int, me: int):
        self.nv = nv
        self.buffers = IDSolveBuffers(*id_solve_buffers(n, nv, p, me))
        self.state, self.rstate = self.buffers.ws_s[:n], self.buffers.ws_s[n:]
        self.residual, self.x = self.buffers.out[:1], self.buffers.out[1:]
        self.max_iterations = 100
        self.tolerance = 1e-6
        self.solves = 0
        self.fallbacks = 0
        self.gave_up = False
        self.cap = self.max_iterations  # the last call's iteration cap
        self._entry = None  # id_solve specialised to C-contiguous float64 arrays (wbc.compiled.specialise)
        self._solution = QPSolution(self.x, self.name)  # every answer: x is this view of the buffer
        self._checked: tuple = (None, False)  # (the last QPData, its arrays all C-contiguous)

    def solve(self, qp: QPData) -> QPSolution:
        """The exact optimum of ``qp`` (x a view of this solver's buffer, overwritten by the next call).

        Raises:
            SolverError: the call did not end in a KKT point within :attr:`tolerance` (the message names its status).
        """
        self.cap = min(self.max_iterations, KERNEL_ITERATIONS_AFTER_GIVE_UP) if self.gave_up else self.max_iterations
        self.gave_up = False
        if qp is not self._checked[0]:  # the formulation hands over the same QPData of views tick after tick
            self._checked = (qp, not CHECK_TYPES and all(a.flags.c_contiguous for a in qp))
        if self._checked[1]:
            if self._entry is None:
                self._entry = specialise(id_solve, qp, self.nv, self.cap, self.buffers)
            it = self._entry(qp, self.nv, self.cap, self.buffers)
        else:
            it = id_solve(qp, self.nv, self.cap, self.buffers)
        if it > 0 and self.residual[0] <= self.tolerance:
            return self._solution
        raise SolverError(self.status_text(it, self.residual[0]))

    def give_up(self) -> float:
        """Record a call that did not answer and clear the working set. Returns its iteration cap."""
        self.fallbacks += 1
        self.gave_up = True
        self.clear()
        return float(self.cap)

    def clear(self) -> None:
        """Clear the working set (the next call starts cold)."""
        self.state[:] = 0
        self.rstate[:] = 0

    @staticmethod
    def status_text(status: int, residual: float) -> str:
        """Why a call of ``status`` (and the solution's ``residual``) did not answer."""
        if status > 0:
            return f"kernel residual {residual:.1e} above the tolerance"
        return f"kernel status {SolverStatus(status).name if status in _STATUS_CODES else status}"

    def warm(self, x: np.ndarray, lam, qp: QPData) -> None:
        """Warm start of the next call from another solver's answer ``x`` (n,) to ``qp``: the signs of its
        multipliers ``lam`` (bounds, equality rows, inequality rows; > 0 at an upper bound) when of the QP's size,
        else the bounds that ``x`` meets (to 1e-9 relative)."""
        n, p, m = self.state.shape[0], self.rstate.shape[0], qp.A.shape[0]
        if lam is not None and len(lam) == n + m + p:
            lam = np.asarray(lam)
            self.state[:] = np.sign(lam[:n])
            self.rstate[:] = np.sign(lam[n + m:])
        else:
            lb, ub = qp.lb, qp.ub
            lo, hi = np.isfinite(lb), np.isfinite(ub)  # an infinite bound is never active
            self.state[lo & (x <= np.where(lo, lb, 0.0) + 1e-9 * np.maximum(1.0, np.abs(np.where(lo, lb, 0.0))))] = -1
            self.state[hi & (x >= np.where(hi, ub, 0.0) - 1e-9 * np.maximum(1.0, np.abs(np.where(hi, ub, 0.0))))] = 1
