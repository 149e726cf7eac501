"""Strict task priorities: a cascade of least-squares QPs (lexicographic optimisation).

Levels 1..p (``KinematicController.add_task(task, level=k)``, k = 0 highest) are each a stack of weighted task
rows  J_k v ≈ v*_k, below them the weighted soft level (tasks with ``level=None``, plus the damping ε‖v‖²). With 𝓗
the hard set (A v = b, l ≤ C v ≤ u, lb ≤ v ≤ ub), level k solves

    v_k = argmin_v ‖J_k v − v*_k‖²   s.t.  v ∈ 𝓗,   J_j v = J_j v_{k−1}  for every level j < k       (P_k)

and the soft level its cost under the same constraints for all p levels. Every minimiser of (P_k) has the same
image J_k v (the cost is strictly convex in it), so fixing it optimises each lower level within the optimal set of
the levels above: the lexicographic order of Kanoun, Lamiraux, Wieber, "Kinematic control of redundant
manipulators: generalizing the task-priority framework to inequality tasks", IEEE T-RO 27(4), 2011, restricted to
equality tasks (Escande, Mansard, Wieber, "Hierarchical quadratic programming", IJRR 33(7), 2014, solve it in one
factorisation). A level that cannot be met is met as well as possible (its slack minimised) and never dropped; the
hard set is never relaxed. Only the soft level is regularised (DAQP's proximal iterations handle the semidefinite
J_kᵀJ_k). Numerically dependent equality rows are dropped before each solve (QR with column pivoting) and their
residual checked after the last one.
"""

from __future__ import annotations

from collections import deque
from typing import Callable

import numpy as np

from wbc.exceptions import SolverError
from wbc.solvers.qp_data import QPData

__all__ = ["band_rows", "solve_lexicographic", "independent_rows"]


#: the last results of :func:`independent_rows` ((A copied, rtol, rows) newest last): a cascade and the re-solves of
#: its tick (contact corrections, trust regions: only b or the box change) ask the same matrices again
_RANK_MEMO: deque = deque(maxlen=6)
#: dgeqp3's workspace size per shape of Aᵀ (:func:`independent_rows`)
_QP3_LWORK: dict[tuple, int] = {}
#: ``memo`` key of :func:`solve_lexicographic` under which it keeps the equality rows of the last cascade that needed
#: its dropped rows as band rows
BAND_KEY = "band"


def independent_rows(A: np.ndarray, rtol: float = 1e-3) -> np.ndarray:
    """Indices of a maximal linearly independent subset of the rows of A (QR with column pivoting of Aᵀ;
    numerical rank: |R_ii| > rtol · max(|R_00|, 1)); (k,) int, sorted, read-only. The last 6
    results are kept: a matrix equal to one of them (same ``rtol``) returns it without a new factorisation."""
    if A.shape[0] == 0:
        return np.zeros(0, dtype=int)
    for M, tol, rows in reversed(_RANK_MEMO):
        if tol == rtol and M.shape == A.shape and np.array_equal(M, A):
            return rows
    from scipy.linalg import lapack

    # LAPACK's dgeqp3 directly (what scipy.linalg.qr(pivoting=True) calls), without forming Q: only |R_ii| and the
    # pivots are needed (≈ 5 µs instead of ≈ 33 µs for 12 × 38 contact rows)
    At = np.array(A.T, dtype=float, order="F")  # a copy: dgeqp3 overwrites it
    lwork = _QP3_LWORK.get(At.shape)  # the workspace query's answer depends on the shape only
    if lwork is None:
        lwork = _QP3_LWORK[At.shape] = int(lapack.dgeqp3(At, lwork=-1)[3][0].real)
    qr, jpvt, _, _, info = lapack.dgeqp3(At, lwork=max(lwork, 1), overwrite_a=True)
    if info != 0:
        raise SolverError(f"QR with column pivoting of the equality rows failed (LAPACK dgeqp3 info {info})")
    # |R_ii| and the rank in plain floats (a few numbers: fewer numpy calls, the same float64 comparisons)
    diag = [abs(x) for x in qr.diagonal().tolist()]
    tol = rtol * max(diag[0], 1.0)
    rank = sum(1 for x in diag if x > tol)
    rows = np.array(sorted(p - 1 for p in jpvt[:rank].tolist()), dtype=jpvt.dtype)
    rows.setflags(write=False)
    _RANK_MEMO.append((np.array(A, dtype=float), rtol, rows))
    return rows


def solve_lexicographic(levels, qp: QPData, backends, final_backend, *, rank_rtol: float = 1e-3,
                        dependent_row_tolerance: float = 1e-3, band: float = 1e-9,
                        stop: Callable[[], bool] | None = None, memo: dict | None = None,
                        level_work: float = 0.0) -> tuple[np.ndarray, list[float]]:
    """Solve the cascade of the module docstring.

    Args:
        levels: list (highest priority first) of (J (m_k, nv), target (m_k,)) with the weights already applied.
        qp: a :class:`~wbc.solvers.qp_data.QPData`: H, g (nv, nv), (nv,) the cost of the soft level (weighted
            tasks + damping); A, b, C, l, u, lb, ub the hard set (see :mod:`wbc.formulations.velocity`).
        backends: one QP backend per level in ``levels`` (each keeps its own warm start).
        final_backend: backend of the soft level.
        rank_rtol: relative rank tolerance of the stacked equality rows.
        dependent_row_tolerance: largest residual accepted on a dropped hard equality row (its units).
        band: half-width of the band |J_j v − J_j v_{k−1}| ≤ band that fixes the upper levels (module docstring).
        stop: asked before each level after the first and after such a level's failed solve (a controller's counted
            tick budget); True: the last solved level's solution is returned (a point of the hard set, optimal for
            every level above), ``solve_lexicographic.last_cut`` the number of levels solved (None: every level).
        memo: a dict the caller keeps across cascades of the same levels, or None: a level's retry that answered last
            time is asked first (forgotten when it fails); under :data:`BAND_KEY` the equality rows A of the last
            cascade that needed its dropped rows as band rows (a cascade on an equal A starts with those bands).
        level_work: solves added to the backends' counted work (``QPBackend.work``) per level started.

    Levels below the point where the kept equality rows and the levels above have rank nv are not solved (v is
    fixed); ``solve_lexicographic.last_determined`` is the first such level (soft level: ``len(levels)``) or None.

    Returns:
        (v (nv,), residuals): the soft level's solution (or the last solved level's: ``stop``) and
        ‖J_k v − v*_k‖ per level.

    Raises:
        SolverError: the first level's QP failed (the hard set has no solution), or dropped (nearly dependent) hard
            rows cannot be held even as ±``dependent_row_tolerance``/2 band rows. A lower level whose QP fails
            numerically is solved again with the upper levels held to the backend's tolerance instead of ``band``,
            else left at the previous level's solution.
    """
    H, g, A, b, C, l, u, lb, ub = qp
    keep = independent_rows(A, rank_rtol)
    dropped = keep.size < A.shape[0]  # nearly dependent equality rows left out
    half = 0.5 * dependent_row_tolerance

    def cascade(banded: bool) -> np.ndarray:
        rows = band_rows(A, b, C, l, u, keep, half) if banded else (A[keep], b[keep], C, l, u)
        return _cascade(levels, QPData(H, g, *rows, lb, ub), backends, final_backend, band, stop, memo, level_work)

    v = None
    if dropped and memo is not None and np.array_equal(memo.get(BAND_KEY), A):
        # an earlier cascade on these equality rows (the same tick's: only b or the box changed since) needed the
        # dropped rows as band rows (below): those bands first, one cascade instead of two; a band cascade that
        # fails is forgotten and the full sequence runs
        try:
            v = cascade(True)
        except SolverError:
            del memo[BAND_KEY]
    if v is None:
        v = cascade(False)
        residual = float(np.max(np.abs(A @ v - b))) if dropped else 0.0
        if residual > dependent_row_tolerance:
            # the dropped rows are only nearly dependent (or disagree): the cascade again with them as band rows
            # |A_d v − b_d| ≤ dependent_row_tolerance / 2 (hard, every level); no solution: they contradict
            try:
                v = cascade(True)
            except SolverError as exc:
                raise SolverError(f"dependent equality rows violated by {residual:.3g} after the hierarchical "
                                  f"solve, and no solution holds them within ±{half:.3g}: {exc}") from None
            if memo is not None:
                memo[BAND_KEY] = np.array(A, dtype=float)
    return v, [float(np.linalg.norm(J @ v - t)) for J, t in levels]


def band_rows(A, b, C, l, u, keep, half) -> tuple:
    """The hard set's rows with the equality rows of A (m, n), b (m,) outside ``keep`` (nearly dependent on those
    in it: :func:`independent_rows`) turned into band rows |A_d v − b_d| ≤ ``half`` (their units) below C (p, n),
    l, u (p,): (A[keep], b[keep], C', l', u')."""
    drop = np.setdiff1d(np.arange(A.shape[0]), keep)
    return (A[keep], b[keep], np.vstack([C, A[drop]]), np.concatenate([l, b[drop] - half]),
            np.concatenate([u, b[drop] + half]))


def _cascade(levels, qp: QPData, backends, final_backend, band, stop=None, memo=None, level_work=0.0):
    """The levels of :func:`solve_lexicographic` on the QP ``qp`` whose equality rows A, b are independent: v.

    A level's QP is asked in turn: the retry ``memo`` recorded for it (a retry that fails is forgotten), the plain
    QP, the ``damped`` retry (cost JᵀJ + μI, μ = 1e-9 · max(|cost|max, max diag JᵀJ): Kanoun et al.'s damped least
    squares, relative bias ~1e-9), the ``wide`` retry (the upper levels' images held within ±tolerance · max(1,
    |J v|) / 2 instead of ±``band``); the first answer stands and a retry's is recorded in ``memo``."""
    H, g, A, b, C, l, u, lb, ub = qp
    fixed_J: list[np.ndarray] = []
    v = None
    n = H.shape[0]
    solve_lexicographic.last_cut = solve_lexicographic.last_determined = None
    for k, ((J, target), backend) in enumerate(zip([*levels, (None, None)], [*backends, final_backend])):
        F = np.vstack(fixed_J) if fixed_J else None
        if F is not None and A.shape[0] + F.shape[0] >= n and independent_rows(np.vstack([A, F])).size == n:
            # the hard equalities and the levels above fix every direction of v (e.g. a posture level over every
            # joint under the contacts): the lower levels have nothing left to optimise — v is their solution too
            # (up to the ±band), and solving them is skipped
            solve_lexicographic.last_determined = k
            break
        if v is not None and stop is not None and stop():  # a count, not a clock: deterministic
            solve_lexicographic.last_cut = k  # levels 0..k-1 solved: v is the last one's solution
            return v
        if level_work and backend.work is not None:
            backend.work.solves += level_work  # the level's rows, rank and band set-up around its QP
        Ck, lk, uk = C, l, u
        if F is not None:
            Fv = F @ v
            Ck, lk, uk = np.vstack([C, F]), np.concatenate([l, Fv - band]), np.concatenate([u, Fv + band])
        Hk, gk = (H, g) if J is None else (J.T @ J, -(J.T @ target))
        # a hand target 1e6 m away at a gain of 1e4 (|g| ~ 3e11) made DAQP cycle or misjudge a level with ±band rows:
        # when |g|∞ ε exceeds the tolerance the cost is divided by max(1, |g|∞, |H|max) (the same minimiser)
        top, scale = float(np.max(np.abs(gk), initial=0.0)), 1.0
        if top * np.finfo(float).eps > backend.tolerance:
            scale = 1.0 / max(1.0, top, float(np.max(np.abs(Hk), initial=0.0)))
            Hk, gk = Hk * scale, gk * scale
        key = (k, len(levels))
        first = memo.get(key) if memo is not None else None
        vk = hard_point = None
        for kind in [*([first] if first else []), "plain", *(r for r in ("damped", "wide") if r != first)]:
            if kind == "damped" and J is None:
                continue
            if kind == "wide" and v is None:
                vk = hard_point  # the first level failed twice on a feasible hard set (numerically): its point
                break
            args = (Hk, gk, A, b, Ck, lk, uk, lb, ub)
            if kind == "damped":
                # semidefinite JᵀJ with a huge target (|g| ~ 1e9 for a 1e6 m target) was measured to leave DAQP
                # 5e-6 – 2e-3 off the rows
                args = (Hk + 1e-9 * max(scale, float(np.max(np.diag(Hk)))) * np.eye(n), *args[1:])
            elif kind == "wide":
                # below the first level the problem is feasible by construction: a failure is numerical (a
                # degenerate ±band); when this fails too, the previous level's v stands
                wide = backend.tolerance * np.maximum(1.0, np.abs(Fv)) * 0.5
                args = (*args[:5], np.concatenate([l, Fv - wide]), np.concatenate([u, Fv + wide]), lb, ub)
            try:
                vk = backend.solve(*args)
            except SolverError as exc:
                failure = exc
            else:
                if kind not in (first, "plain") and memo is not None:
                    memo[key] = kind
                break
            if kind == first:
                del memo[key]  # the hint failed: the full sequence (which records what solves now)
            if kind in (first, "plain") and v is not None and stop is not None and stop():
                # the budget ran out inside this level's solve (a backend bounds its solver's iterations by the work
                # left, e.g. DaqpBackend.call_limit): no retry — cut here, as before a level
                solve_lexicographic.last_cut = k
                return v
            if kind == "plain" and v is None:
                # the first level failed: is the hard set itself infeasible? (min ‖v‖² on it, a well-conditioned QP)
                # — asked before the damped retry, so that an infeasible hard set costs two solves, not three
                try:
                    hard_point = backend.solve(np.eye(n), np.zeros(n), A, b, C, l, u, lb, ub)
                except SolverError:
                    raise SolverError(f"priority level {k} of {len(levels)}: {failure}" if J is not None else
                                      f"soft level below {len(levels)} priority levels: {failure}") from None
        if vk is not None:
            v = vk
        if J is not None:
            fixed_J.append(J)
    return v


solve_lexicographic.last_determined = None
solve_lexicographic.last_cut = None
