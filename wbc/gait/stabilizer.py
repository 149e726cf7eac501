"""The DCM stabilizer of a walk: a control law on the CoM state, testable without a simulator.

:class:`DcmStabilizer` turns the measured CoM position and velocity and the plan's DCM and ZMP references into the
horizontal CoM acceleration sent to the whole-body QP (DCM feedback with integral action, the commanded CoP kept in
the support area, optionally the CMP beyond it: the hip strategy). :func:`stabilizer_kernel` is the same law in one
compiled call with the support area built from the soles' corners (:func:`support_kernel`), what
:class:`wbc.sim.walk.WalkScenario` calls every tick; ``tests/gait/test_stabilizer.py`` checks both give the same
numbers bit for bit.

Frames and units: world, z up; m, s.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from wbc.exceptions import InvalidInputError
from wbc.geometry import polygon_margin

__all__ = ["DcmStabilizer", "closest_point_xy", "stabilizer_kernel", "support_kernel"]


class DcmStabilizer:
    """DCM tracking with CoP feedback and integral action, commanded CoP kept in the support area.

    LIPM: c̈ = ω² (c − p), DCM ξ = c + ċ/ω, ξ̇ = ω (ξ − p) (Englsberger, Ott, Albu-Schäffer 2015, IEEE T-RO 31(2),
    eqs. 3–6). The desired CoP (Englsberger 2015 eq. 29 with gain k_ξ; Caron, Kheddar, Tempier 2019, "Stair
    climbing stabilization of the HRP-4 humanoid robot using whole-body admittance control", ICRA, eq. 9, DCM
    feedback with proportional and integral terms):

        p_d = p_ref + k_p (ξ − ξ_ref) + k_i ∫ (ξ − ξ_ref) dt,      k_p = 1 + k_ξ/ω > 1

    which gives ξ̇ − ξ̇_ref = −k_ξ (ξ − ξ_ref) − ω k_i ∫… for an exact LIPM. ``p_d`` is projected onto the
    support area (the convex hull of the soles in contact, each shrunk by ``margin``); the integral is frozen
    while the projection is active (anti-windup) and clipped to ``i_max``. The CoM acceleration sent to the
    whole-body QP is c̈_d = ω² (c − p_d) (LIPM eq. 1). CoP feedback (Caron 2019 eq. 10's ZMP term) is
    ``k_z (p_d − p_measured)`` added to p_d when a measured CoP is given (default k_z = 0: the QP's contact
    forces realise p_d directly).

    **Hip strategy** (``cmp_offset`` > 0): when ``p_d`` lies outside the support area, the point sent to the QP is
    the centroidal moment pivot (CMP) ``r = p_c + min(‖p_d − p_c‖, cmp_offset) (p_d − p_c)/‖p_d − p_c‖`` (``p_c`` the
    projected CoP), c̈_d = ω² (c − r): with a rate of centroidal angular momentum the CMP leaves the support
    polygon while the CoP stays in it, ``r_cmp = p − (L̇ × e_z)_xy … / F_z`` (Popovic, Goswami, Herr, "Ground reference
    points in legged locomotion", IJRR 24(12), 2005), and ξ̇ = ω (ξ − r_cmp) (Englsberger 2015, with the CMP in place
    of the CoP); Hofmann, Popovic, Herr, "Exploiting angular momentum to enhance bipedal center-of-mass control",
    ICRA 2009, use this bounded CMP–CoP offset as the hip strategy. The whole-body QP realises the difference by
    upper-body rotation (its CoM task outweighs its angular-momentum and torso tasks,
    :mod:`wbc.dynamics.balance`).

    Args:
        omega: LIPM frequency √(g/z_c) (1/s).
        k_xi: DCM gain k_ξ (1/s, ≥ 0). k_i: integral gain (1/s, ≥ 0). k_z: CoP feedback gain (≥ 0).
        margin: CoP margin from the sole edges (m). i_max: integral clip (m·s). dt: period (s).
        cmp_offset: largest CMP distance outside the support area (m, ≥ 0; 0: none).
    """

    def __init__(self, omega: float, *, k_xi: float = 3.0, k_i: float = 1.0, k_z: float = 0.0,
                 margin: float = 0.015, i_max: float = 0.05, dt: float = 0.002, cmp_offset: float = 0.0):
        for val, what in ((omega, "omega"), (dt, "dt")):
            if not (np.isfinite(val) and val > 0):
                raise InvalidInputError(f"{what} must be finite and > 0, got {val!r}")
        for val, what in ((k_xi, "k_xi"), (k_i, "k_i"), (k_z, "k_z"), (margin, "margin"), (i_max, "i_max")):
            if not (np.isfinite(val) and val >= 0):
                raise InvalidInputError(f"{what} must be finite and ≥ 0, got {val!r}")
        self.omega, self.dt = float(omega), float(dt)
        self.k_p = 1.0 + k_xi / omega
        self.k_i, self.k_z, self.margin, self.i_max = float(k_i), float(k_z), float(margin), float(i_max)
        if not (np.isfinite(cmp_offset) and cmp_offset >= 0):
            raise InvalidInputError(f"cmp_offset must be finite and ≥ 0 m, got {cmp_offset!r}")
        self.cmp_offset = float(cmp_offset)
        self.integral = np.zeros(2)
        self.last_cop = np.zeros(2)
        self.last_cmp = np.zeros(2)
        self.saturated = False

    def law(self) -> tuple:
        """This stabilizer's numbers for :func:`stabilizer_kernel`: (omega, k_p, k_i, k_z, i_max, dt, cmp_offset,
        integral, last_cop, last_cmp), the arrays themselves (the kernel updates them); a plain tuple, built per
        tick (cheaper than a namedtuple)."""
        return (self.omega, self.k_p, self.k_i, self.k_z, self.i_max, self.dt, self.cmp_offset, self.integral,
                self.last_cop, self.last_cmp)

    def __call__(self, c: np.ndarray, cd: np.ndarray, xi_ref: np.ndarray, p_ref: np.ndarray,
                 hull, p_meas: np.ndarray | None = None) -> np.ndarray:
        """Horizontal CoM acceleration (2,) (m/s²) from CoM c (2,), ċ (2,), references ξ_ref, p_ref (2,) and the
        support hull (m, 2) (already shrunk by the margin; an array or a list of ``(x, y)`` vertices, CCW)."""
        if isinstance(hull, np.ndarray):
            hull = hull.tolist()

        def project(px: float, py: float) -> tuple[float, float]:
            return closest_point_xy(px, py, hull) if len(hull) >= 3 else (px, py)

        ax, ay = self.acceleration(float(c[0]), float(c[1]), float(cd[0]), float(cd[1]), float(xi_ref[0]),
                                   float(xi_ref[1]), float(p_ref[0]), float(p_ref[1]), project, p_meas)
        return np.array([ax, ay])

    def acceleration(self, cx: float, cy: float, cdx: float, cdy: float, xrx: float, xry: float, prx: float,
                     pry: float, project, p_meas) -> tuple[float, float]:
        """:meth:`__call__` on floats (the same arithmetic, element by element; no array made for the inputs):
        (c̈_x, c̈_y) m/s² from the CoM (cx, cy) m, its velocity (cdx, cdy) m/s, the references ξ_ref (xrx, xry) m and
        p_ref (prx, pry) m, world frame; ``project(x, y)`` returns the closest point ``(x, y)`` of the support area;
        ``p_meas`` the measured CoP (2,) m or None. Updates the integral, ``last_cop``, ``last_cmp`` (written in
        place, (2,) float arrays) and ``saturated``."""
        w = self.omega
        ex, ey = cx + cdx / w - xrx, cy + cdy / w - xry
        ix, iy = self.integral.tolist()
        px, py = prx + self.k_p * ex + self.k_i * ix, pry + self.k_p * ey + self.k_i * iy
        if self.k_z > 0 and p_meas is not None:
            px, py = px + self.k_z * (px - float(p_meas[0])), py + self.k_z * (py - float(p_meas[1]))
        qx, qy = project(px, py)
        dx, dy = px - qx, py - qy
        out = math.sqrt(dx * dx + dy * dy)
        self.saturated = out > 1e-9
        if not self.saturated:
            i_max = self.i_max
            self.integral[0] = min(max(ix + ex * self.dt, -i_max), i_max)
            self.integral[1] = min(max(iy + ey * self.dt, -i_max), i_max)
        self.last_cop[0], self.last_cop[1] = qx, qy
        rx, ry = qx, qy
        if self.saturated and self.cmp_offset > 0:  # CMP beyond the CoP's reach: angular momentum (hip strategy)
            f = min(out, self.cmp_offset) / out
            rx, ry = qx + f * dx, qy + f * dy
        self.last_cmp[0], self.last_cmp[1] = rx, ry
        return w * w * (cx - rx), w * w * (cy - ry)


def closest_point_xy(px: float, py: float, poly: list) -> tuple[float, float]:
    """:func:`wbc.geometry.closest_point_in_polygon` on floats: the closest point of a CCW convex polygon (list of
    ``(x, y)`` vertices, m) to ``(px, py)`` (m): the point itself inside, else its projection on the nearest edge."""
    if polygon_margin((px, py), poly) >= 0:
        return px, py
    best, dbest = (px, py), math.inf
    m = len(poly)
    for i in range(m):
        ax, ay = poly[i]
        bx, by = poly[(i + 1) % m]
        ex, ey = bx - ax, by - ay
        s = min(max(((px - ax) * ex + (py - ay) * ey) / (ex * ex + ey * ey), 0.0), 1.0)
        qx, qy = ax + s * ex, ay + s * ey
        dx, dy = px - qx, py - qy
        dd = math.sqrt(dx * dx + dy * dy)
        if dd < dbest:
            best, dbest = (qx, qy), dd
    return best


@nb.njit(cache=True, nogil=True)
def support_kernel(xy, tx0, ty0, tx1, ty1, ns, px, py):
    """Hull of the ``ns`` (1 or 2) soles' corners and the point (px, py) (m, world xy) against it: ``xy`` (4, 3 ns) the
    corners in the soles' rotated frames (the walk scenario's support area), (tx_j, ty_j) the soles' positions.
    Returns (number of hull vertices m, :func:`~wbc.geometry.polygon_margin`, closest point x, y) with the arithmetic
    of :func:`wbc.geometry.hull`, :func:`~wbc.geometry.polygon_margin` and :func:`closest_point_xy` (m < 3: the margin
    NaN and the point itself)."""
    n = 4 * ns
    pts = np.empty((n, 2))
    for r in range(4):
        pts[r, 0] = xy[r, 0] + tx0
        pts[r, 1] = xy[r, 1] + ty0
        if ns == 2:
            pts[4 + r, 0] = xy[r, 3] + tx1
            pts[4 + r, 1] = xy[r, 4] + ty1
    order = np.arange(n)
    for i in range(1, n):  # insertion sort, lexicographic (x, y) as Python's sort of tuples
        j = i
        while j > 0:
            a, b = order[j - 1], order[j]
            if pts[b, 0] < pts[a, 0] or (pts[b, 0] == pts[a, 0] and pts[b, 1] < pts[a, 1]):
                order[j - 1], order[j] = b, a
                j -= 1
            else:
                break
    hv = np.empty((2 * n, 2))
    m = 0
    for half in range(2):  # lower then upper chain (the sorted points reversed), each without its last point
        start = m
        for ii in range(n):
            p = order[ii] if half == 0 else order[n - 1 - ii]
            qx, qy = pts[p, 0], pts[p, 1]
            while m - start >= 2:
                ox, oy = hv[m - 2, 0], hv[m - 2, 1]
                ax, ay = hv[m - 1, 0], hv[m - 1, 1]
                if not (ax - ox) * (qy - oy) - (ay - oy) * (qx - ox) <= 0.0:
                    break
                m -= 1
            hv[m, 0], hv[m, 1] = qx, qy
            m += 1
        m -= 1
    if m < 3:
        return m, np.nan, px, py
    d = np.inf
    ax, ay = hv[m - 1, 0], hv[m - 1, 1]
    for i in range(m):
        bx, by = hv[i, 0], hv[i, 1]
        ex, ey = bx - ax, by - ay
        val = (ex * (py - ay) - ey * (px - ax)) / math.sqrt(ex * ex + ey * ey)
        if val < d:
            d = val
        ax, ay = bx, by
    if d >= 0:
        return m, d, px, py
    bestx, besty, dbest = px, py, np.inf
    for i in range(m):
        ax, ay = hv[i, 0], hv[i, 1]
        j = (i + 1) % m
        ex, ey = hv[j, 0] - ax, hv[j, 1] - ay
        s = ((px - ax) * ex + (py - ay) * ey) / (ex * ex + ey * ey)
        if 0.0 > s:
            s = 0.0
        if 1.0 < s:
            s = 1.0
        qx, qy = ax + s * ex, ay + s * ey
        dx, dy = px - qx, py - qy
        dd = math.sqrt(dx * dx + dy * dy)
        if dd < dbest:
            bestx, besty, dbest = qx, qy, dd
    return m, d, bestx, besty


@nb.njit(cache=True)
def stabilizer_kernel(xy, ns, pos0, pos1, c, cd, ref_dcm, ref_zmp, p_meas, law):
    """:meth:`DcmStabilizer.acceleration`, its support area the hull of :func:`support_kernel` (the
    ``ns`` soles' corners ``xy`` (4, 3 ns) in their rotated frames, the soles at ``pos0``, ``pos1`` (3,); ``ns`` = 0:
    no projection), on the CoM ``c`` and its velocity ``cd`` (3,) and the references ``ref_dcm``, ``ref_zmp`` (2,),
    the measured CoP ``p_meas`` (2,) fed back with gain ``k_z`` (none when k_z ≤ 0 or ``p_meas`` is NaN), with the
    same arithmetic element by element; ``law``: the stabilizer's gains and state (:meth:`DcmStabilizer.law`). Writes
    ``integral``, ``last_cop``, ``last_cmp`` (2,) in place. Returns (number of hull vertices m (3 when ns = 0; m < 3:
    nothing written), c̈_x, c̈_y (m/s²), saturated)."""
    omega, k_p, k_i, k_z, i_max, dt, cmp_offset, integral, last_cop, last_cmp = law
    cx, cy, cdx, cdy = c[0], c[1], cd[0], cd[1]
    w = omega
    ex, ey = cx + cdx / w - ref_dcm[0], cy + cdy / w - ref_dcm[1]
    ix, iy = integral[0], integral[1]
    px, py = ref_zmp[0] + k_p * ex + k_i * ix, ref_zmp[1] + k_p * ey + k_i * iy
    if k_z > 0 and p_meas[0] == p_meas[0]:
        px, py = px + k_z * (px - p_meas[0]), py + k_z * (py - p_meas[1])
    m = 3
    qx, qy = px, py
    if ns > 0:
        m, _, qx, qy = support_kernel(xy, pos0[0], pos0[1], pos1[0], pos1[1], ns, px, py)
        if m < 3:
            return m, 0.0, 0.0, False
    dx, dy = px - qx, py - qy
    out = math.sqrt(dx * dx + dy * dy)
    saturated = out > 1e-9
    if not saturated:  # min(max(a, -i_max), i_max) as Python's min and max
        a, b = ix + ex * dt, iy + ey * dt
        if -i_max > a:
            a = -i_max
        if i_max < a:
            a = i_max
        if -i_max > b:
            b = -i_max
        if i_max < b:
            b = i_max
        integral[0], integral[1] = a, b
    last_cop[0], last_cop[1] = qx, qy
    rx, ry = qx, qy
    if saturated and cmp_offset > 0:
        f = out
        if cmp_offset < f:
            f = cmp_offset
        f = f / out
        rx, ry = qx + f * dx, qy + f * dy
    last_cmp[0], last_cmp[1] = rx, ry
    return m, w * w * (cx - rx), w * w * (cy - ry), saturated
