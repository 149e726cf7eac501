"""The compiled kernels of :class:`wbc.constraints.self_collision.SelfCollisionConstraint` (its module docstring
states the math): the conservative broad phase over the pairs' bounding spheres and known distances
(:func:`broad_phase`), the bookkeeping after the narrow phase (:func:`narrow_phase_done`), the close pairs with their
velocity-damper rows (:func:`close_pairs`, :func:`pair_dampers`, :func:`close_pairs_damper`). The constraint's state
is held in two namedtuple workspaces of arrays, built once and updated in place: :class:`BroadPhaseState` and
:class:`DamperRows`."""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np

__all__ = ["BOUND_SLACK", "BroadPhaseState", "DamperRows", "broad_phase", "close_pairs", "close_pairs_damper",
           "damper_rows", "narrow_phase_done", "pair_dampers"]


#: m subtracted from every lower bound of the broad phase (rounding of the bounds, GJK's 1e-9 m tolerance)
BOUND_SLACK = 1e-6


@nb.njit(cache=True, nogil=True, inline="always")
def _relative(rot, centre, joint, radius, a, b, out):
    """The relative placement of pair (a, b) in the root joint's frame written to ``out`` (12,): the rotation
    R_fᵀR_m (row-major) and the sphere centre Rᵀ_f (c_m − c_f) of the moving geometry m in the frame of the fixed one
    f, where m is the one of a, b with the smaller bounding radius; returns that radius."""
    f, m = (b, a) if radius[a] < radius[b] else (a, b)
    jf, jm = joint[f], joint[m]
    for i in range(3):
        for j in range(3):
            x = 0.0
            for k in range(3):
                x += rot[jf, k, i] * rot[jm, k, j]
            out[3 * i + j] = x
        x = 0.0
        for k in range(3):
            x += rot[jf, k, i] * (centre[m, k] - centre[f, k])
        out[9 + i] = x
    return radius[m]


@nb.njit(cache=True, nogil=True, inline="always")
def _relative_bound(rot, centre, joint, radius, a, b, then, now):
    """Bound (m) on the displacement of any point of the pair's moving geometry (``_relative``) in the fixed one's
    frame since the relative placement ``then`` (12,): |Δc| + ‖ΔR‖₂ r with ‖ΔR‖₂ = ‖ΔR‖_F / √2 (the difference of two
    rotations; module docstring). A distance is 1-Lipschitz in that displacement (it does not change under a motion
    common to both bodies). ``now`` (12,): scratch."""
    r = _relative(rot, centre, joint, radius, a, b, now)
    dr = 0.0
    for i in range(9):
        dr += (now[i] - then[i]) ** 2
    dc = 0.0
    for i in range(9, 12):
        dc += (now[i] - then[i]) ** 2
    return np.sqrt(dc) + np.sqrt(0.5 * dr) * r


class BroadPhaseState(NamedTuple):
    """The broad phase's state (:func:`broad_phase`; :class:`SelfCollisionConstraint` builds it once, the arrays
    updated in place), with ng geometries, nj joints, npairs watched pairs and k_max rows."""

    ref: int                   #: the root joint, whose frame the displacements are expressed in
    k_max: int                 #: the most rows (max_active)
    joint: np.ndarray          #: (ng,) int64 parent joint of each geometry
    centre_local: np.ndarray   #: (ng, 3) bounding sphere centre, in its joint's frame (m)
    radius: np.ndarray         #: (ng,) bounding sphere radius (m)
    pairs: np.ndarray          #: (npairs, 2) int64 geometry indices of each pair
    prev_c: np.ndarray         #: (ng, 3) sphere centres of the previous call
    prev_r: np.ndarray         #: (nj, 3, 3) joint rotations of the previous call
    moved: np.ndarray          #: (ng,) accumulated bound on each geometry's displacement (m)
    moved_at: np.ndarray       #: (npairs,) moved_a + moved_b when coal last computed the pair
    d_known: np.ndarray        #: (npairs,) the pair's distance then (m)
    exact: np.ndarray          #: (npairs,) bool: whether coal ever computed the pair
    on: np.ndarray             #: (npairs,) bool: the pairs active in the ``GeometryData``
    toggle: np.ndarray         #: (npairs,) int64 out: the pairs to switch there (k on, ~k off)
    cand: np.ndarray           #: (npairs,) int64 out: the candidates
    buf: np.ndarray            #: (npairs,) scratch of the upper bounds
    rows: np.ndarray           #: (k_max,) int64 out: positions in ``cand`` of the closest pairs
    rel: np.ndarray            #: (npairs, 12) relative placement when coal last computed the pair
    scratch: np.ndarray        #: (12,) scratch
    gap_known: np.ndarray      #: (npairs,) the pair's sphere gap when last computed (m; −inf: none)
    gap_at: np.ndarray         #: (npairs,) moved_a + moved_b then


class DamperRows(NamedTuple):
    """The velocity-damper rows' buffers and per-pair memory (:func:`pair_dampers`), built once."""

    pair_joint: np.ndarray  #: (npairs, 2) int64 parent joints of each pair's geometries
    support: np.ndarray     #: (njoints, 1 + nv) int32: per joint the count of its support's columns, then those
    C: np.ndarray           #: (rows, nv) out: the rows
    l: np.ndarray           #: (rows,) out: their lower bounds
    floor: np.ndarray       #: (npairs,) each pair's floor f (m; NaN: none yet)
    slot_of: np.ndarray     #: (npairs,) int64: a pair's row, or −1
    in_slot: np.ndarray     #: (rows,) int64: a row's pair, or −1
    slot: np.ndarray        #: (rows,) int64 out: the row of each close pair


@nb.njit(cache=True, nogil=True)
def broad_phase(placements, first, activation, s):
    """Candidate pairs of one call (module docstring: broad phase); their indices (increasing) written to ``cand``.
    ``s``: the state (:class:`BroadPhaseState`, its fields below; updated). ``on`` (npairs,) bool: the pairs active
    in the ``GeometryData`` (updated to the candidates); ``toggle`` (npairs,) out: the pairs to switch there, k to
    activate, ~k (= −k − 1) to deactivate. Returns (candidates, toggles).

    ``placements`` (njoints, 12) joint placements (``data.oMi``: rotation column-major, then translation; the layout
    of ``_joint_placements``), expressed here in the frame of joint ``ref``
    (distances do not depend on the frame; the root joint's frame leaves out the floating base's motion).
    ``joint`` (ngeoms,) parent joint of each geometry, ``centre_local`` (ngeoms, 3) / ``radius`` (ngeoms,) its
    bounding sphere in that joint's frame. State, updated: ``prev_c`` (ngeoms, 3) sphere centres and ``prev_r``
    (njoints, 3, 3) rotations of the previous call (unused when ``first``), ``moved`` (ngeoms,) accumulated bound on
    each geometry's displacement (|Δc| + ‖ΔR‖_F r / √2 per call), ``moved_at`` (npairs,) moved_a + moved_b when
    coal last computed the pair (raised to moved_a + moved_b − δ when the relative bound δ is the smaller: d_known ±
    (moved_a + moved_b − moved_at) then bounds the distance from there on), ``d_known`` its distance then,
    ``exact`` whether it was ever computed.
    ``rel`` (npairs, 12) the pair's relative placement (``_relative``) when coal last computed it (recorded, from
    ``prev_c``/``prev_r``, by the call at which a pair computed at the previous call is no longer a candidate).
    Per pair: lower bound L = max(sphere gap, d_known − δ) with the motion bound δ = moved_a + moved_b − moved_at,
    or the smaller ``_relative_bound`` since ``rel`` where δ leaves a pair that was no candidate at the previous call
    in question; upper bound U = d_known + (moved_a + moved_b − moved_at) (inf if not ``exact``); τ = the k_max-th
    smallest U below ``activation`` (``activation`` if fewer); candidates: L < activation and L ≤ τ. The sphere gap
    is kept as a bound too: ``gap_known`` (npairs,) the pair's gap when last computed (−inf: none), ``gap_at``
    moved_a + moved_b then; it is recomputed only when gap_known − (moved_a + moved_b − gap_at) leaves the pair in
    question. ``scratch`` (12,): work space."""
    ref, joint, centre_local, radius, pairs = s.ref, s.joint, s.centre_local, s.radius, s.pairs
    prev_c, prev_r, moved, moved_at, d_known, exact = s.prev_c, s.prev_r, s.moved, s.moved_at, s.d_known, s.exact
    k_max, on, toggle, cand, buf, rel, scratch = s.k_max, s.on, s.toggle, s.cand, s.buf, s.rel, s.scratch
    gap_known, gap_at = s.gap_known, s.gap_at
    nj = placements.shape[0]
    ng = joint.shape[0]
    rot = np.empty((nj, 3, 3))
    pos = np.empty((nj, 3))
    for s in range(nj):
        for i in range(3):
            for j in range(3):
                x = 0.0
                for k in range(3):
                    x += placements[ref, 3 * i + k] * placements[s, 3 * j + k]  # R_ref[k, i] R_s[k, j]
                rot[s, i, j] = x
            x = 0.0
            for k in range(3):
                x += placements[ref, 3 * i + k] * (placements[s, 9 + k] - placements[ref, 9 + k])
            pos[s, i] = x
    centre = np.empty((ng, 3))
    for g in range(ng):
        s = joint[g]
        dc = 0.0
        for i in range(3):
            c = pos[s, i]
            for j in range(3):
                c += rot[s, i, j] * centre_local[g, j]
            centre[g, i] = c
            dc += (c - prev_c[g, i]) ** 2
        if not first:
            dr = 0.0
            for i in range(3):
                for j in range(3):
                    dr += (rot[s, i, j] - prev_r[s, i, j]) ** 2
            moved[g] += np.sqrt(dc) + np.sqrt(0.5 * dr) * radius[g]
    npairs = pairs.shape[0]
    nu = 0
    for k in range(npairs):
        if exact[k]:
            u = d_known[k] + (moved[pairs[k, 0]] + moved[pairs[k, 1]] - moved_at[k])
            if u < activation:
                buf[nu] = u
                nu += 1
    tau = activation
    if nu >= k_max:
        tau = np.sort(buf[:nu])[k_max - 1]
    n = 0
    nt = 0
    for k in range(npairs):
        a = pairs[k, 0]
        b = pairs[k, 1]
        was_on = on[k]
        if was_on:  # assumed dropped; switched back on below if it is a candidate
            toggle[nt] = ~k
            nt += 1
            on[k] = False
        # the bounds are computed in floating point and coal's distances are exact only to GJK's tolerance: a pair
        # whose bound is within BOUND_SLACK of the cut-off is kept (e.g. humanoid15's pair 18, at a constant
        # 0.12 − 1 ulp m, was dropped at activation 0.12 by a sphere gap rounded up to 0.12). L is the larger of
        # the two bounds: either one at or above the cut-off excludes the pair (the cheaper one first)
        keep = False
        while True:  # one pass: break when a bound excludes the pair
            if exact[k]:
                low = d_known[k] - (moved[a] + moved[b] - moved_at[k]) - BOUND_SLACK
                if low >= activation or low > tau:
                    break
                if not was_on:  # (a pair computed at the previous call: its summed motions are one call's)
                    delta = _relative_bound(rot, centre, joint, radius, a, b, rel[k], scratch)
                    if delta < moved[a] + moved[b] - moved_at[k]:  # the summed motions count from here on
                        moved_at[k] = moved[a] + moved[b] - delta
                    low = d_known[k] - delta - BOUND_SLACK
                    if low >= activation or low > tau:
                        break
            low = gap_known[k] - (moved[a] + moved[b] - gap_at[k]) - BOUND_SLACK
            if low >= activation or low > tau:
                break
            d2 = 0.0
            for i in range(3):
                d2 += (centre[a, i] - centre[b, i]) ** 2
            gap = np.sqrt(d2) - radius[a] - radius[b]
            gap_known[k] = gap
            gap_at[k] = moved[a] + moved[b]
            low = gap - BOUND_SLACK
            keep = low < activation and low <= tau
            break
        if not keep:
            if was_on and exact[k]:  # computed by coal at the previous call, at its placements: kept for rel
                _relative(prev_r, prev_c, joint, radius, a, b, rel[k])
            continue
        cand[n] = k
        n += 1
        if nt > 0 and toggle[nt - 1] == ~k:  # active and staying so
            nt -= 1
        else:
            toggle[nt] = k
            nt += 1
        on[k] = True
    prev_c[:] = centre
    prev_r[:] = rot
    return n, nt


@nb.njit(cache=True, nogil=True)
def narrow_phase_done(n, dist, activation, s):
    """Record the coal distances ``dist`` of the first n candidates ``s.cand`` (:class:`BroadPhaseState`) and write
    to ``s.rows`` the positions in ``cand`` of the (at most k_max) closest below ``activation``, closest first
    (ties: lower pair index first); returns their count."""
    cand, pairs, d_known, exact, moved, moved_at = s.cand, s.pairs, s.d_known, s.exact, s.moved, s.moved_at
    for i in range(n):
        k = cand[i]
        d_known[k] = dist[i]
        exact[k] = True
        moved_at[k] = moved[pairs[k, 0]] + moved[pairs[k, 1]]
    order = np.argsort(dist, kind="mergesort")
    m = 0
    for i in order:
        if m == s.k_max or dist[i] >= activation:
            break
        s.rows[m] = i
        m += 1
    return m


@nb.njit(cache=True, nogil=True)
def close_pairs(n, found, activation, s):
    """:func:`narrow_phase_done` for the first n candidates of the state ``s``, their results in ``found`` (the
    compiled narrow phase's output: n distances, then n witness points p1, then n normals), and the rows' arrays of
    :class:`ClosePairs` (fresh): pair indices, distances, normals, p1, p2 = p1 + d n."""
    dist = found[:n]
    m = narrow_phase_done(n, dist, activation, s)
    cand, rows = s.cand, s.rows
    k = np.empty(m, dtype=np.int64)
    d = np.empty(m)
    normal = np.empty((m, 3))
    p1 = np.empty((m, 3))
    p2 = np.empty((m, 3))
    for i in range(m):
        r = rows[i]
        k[i] = cand[r]
        d[i] = dist[r]
        for j in range(3):
            p1[i, j] = found[n + 3 * r + j]
            normal[i, j] = found[4 * n + 3 * r + j]
            p2[i, j] = p1[i, j] + d[i] * normal[i, j]
    return k, d, normal, p1, p2


@nb.njit(cache=True, nogil=True)
def damper_rows(normal, p1, p2, joint1, joint2, J, support, C, slot):
    """C[slot[r]] += nᵀJ2,lin + (p2 × n)ᵀJ2,ang − nᵀJ1,lin − (p1 × n)ᵀJ1,ang on each body's support columns (module
    docstring), for r < normal.shape[0]; C's other entries untouched. ``support`` (njoints, 1 + nv) int32: row j
    holds the number of columns of joint j's support, then those columns."""
    for i in range(normal.shape[0]):
        r = slot[i]
        n0, n1, n2 = normal[i, 0], normal[i, 1], normal[i, 2]
        for side in range(2):
            p = p2[i] if side == 1 else p1[i]
            sign = 1.0 if side == 1 else -1.0
            jt = joint2[i] if side == 1 else joint1[i]
            x0 = p[1] * n2 - p[2] * n1
            x1 = p[2] * n0 - p[0] * n2
            x2 = p[0] * n1 - p[1] * n0
            for t in range(1, support[jt, 0] + 1):
                c = support[jt, t]
                C[r, c] += sign * (n0 * J[0, c] + n1 * J[1, c] + n2 * J[2, c]
                                   + x0 * J[3, c] + x1 * J[4, c] + x2 * J[5, c])


@nb.njit(cache=True, nogil=True)
def pair_dampers(k, d, p1, p2, normal, J, rows, gamma, ds, rise):
    """The velocity-damper rows of the m = len(k) close pairs (module docstring), each pair's floor
    f = min(ds, max(f_prev, d) + rise) (min(ds, d) when f_prev is NaN) and l = −γ (d − f), written to ``rows``
    (:class:`DamperRows`: C, l, floor); the unused rows C = 0, l = −∞.

    Rows are slots kept across calls (``rows.slot_of`` (npairs,): a pair's row or −1; ``rows.in_slot`` (rows,): a
    row's pair or −1): a pair that stays active keeps its row, a new one takes the lowest free row. The QP is the
    same in any row order; a stable order lets the solver's warm start (its working set, by row index) carry over
    from one tick to the next. ``rows.slot`` (≥ m,): out, the row of each pair of k."""
    slot_of, in_slot, slot, C, l, floor = rows.slot_of, rows.in_slot, rows.slot, rows.C, rows.l, rows.floor
    m = k.shape[0]
    for r in range(in_slot.shape[0]):  # free the rows of the pairs no longer active
        q = in_slot[r]
        if q >= 0:
            keep = False
            for i in range(m):
                if k[i] == q:
                    keep = True
                    break
            if not keep:
                slot_of[q] = -1
                in_slot[r] = -1
    free = 0
    for i in range(m):
        r = slot_of[k[i]]
        if r < 0:
            while in_slot[free] >= 0:
                free += 1
            r = free
            slot_of[k[i]] = r
            in_slot[r] = k[i]
        slot[i] = r
    C[:, :] = 0.0
    l[:] = -np.inf
    damper_rows(normal, p1, p2, rows.pair_joint[k, 0], rows.pair_joint[k, 1], J, rows.support, C, slot)
    for i in range(m):
        f = floor[k[i]]
        f = d[i] if np.isnan(f) else max(f, d[i]) + rise
        f = min(ds, f)
        floor[k[i]] = f
        l[slot[i]] = -gamma * (d[i] - f)


@nb.njit(cache=True, nogil=True)
def close_pairs_damper(n, found, activation, s, J, rows, gamma, ds, rise):
    """:func:`close_pairs` then :func:`pair_dampers` on its rows in one compiled call. Returns the rows' arrays of
    :class:`ClosePairs`."""
    k, d, normal, p1, p2 = close_pairs(n, found, activation, s)
    pair_dampers(k, d, p1, p2, normal, J, rows, gamma, ds, rise)
    return k, d, normal, p1, p2
