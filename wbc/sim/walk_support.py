"""The support area of a physics walk (:class:`wbc.sim.walk.WalkScenario`): the convex hull of the soles in contact
(cut to their bands on partial footholds), the point's margin in it and the DCM stabilizer's call over it
(:class:`WalkSupport`); the heights measured on uneven ground (the stance sole's relative height, the supporting
soles' height offset of the CoM, the swing sole's blended offset) and the partial footholds of a blind walk."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.compiled import CHECK_TYPES, specialise
from wbc.gait.blind import BLIND_CUT_LOAD, clip_band_range, roll_band
from wbc.gait.stabilizer import closest_point_xy, stabilizer_kernel, support_kernel
from wbc.geometry import convex_hull, polygon_margin
from wbc.geometry import hull as hull_vertices
from wbc.profiles import min_jerk

__all__ = ["WalkSupport", "BLIND_SUPPORT_TAU"]


#: Blind walk: time constant (s) of the low-pass filter on the supporting soles' measured − planned height that is
#: added to the planned CoM height (:meth:`WalkSupport._support_offset`).
BLIND_SUPPORT_TAU = 0.2


class WalkSupport:
    """The support area and the measured ground heights of :class:`wbc.sim.walk.WalkScenario` (its state: the
    switcher, the sole placements of the tick, the plan)."""

    _stabilizer_kernel = None  # _stabilize's compiled call, specialised at its first call

    def _sole_corners(self, shrink: float) -> np.ndarray:
        """(4, 3) corners (m, sole frame) of the sole rectangle shrunk by ``shrink``, in the order of
        :func:`~wbc.geometry.projected_sole_corners` (cached per shrink)."""
        corners = self._corners.get(shrink)
        if corners is None:
            r = self.robot
            a, b = 0.5 * (r.sole_length - 2 * shrink), 0.5 * (r.sole_width - 2 * shrink)
            corners = self._corners[shrink] = np.array([[a, b, 0.0], [-a, b, 0.0], [-a, -b, 0.0], [a, -b, 0.0]])
        return corners

    def _hull(self, shrink: float) -> list:
        """CCW vertices ``(x, y)`` (m, world) of the convex hull of the soles in contact (their rectangles shrunk by
        ``shrink``, cut to their bands (:meth:`_partial_footholds`)), projected on the ground, at the state of
        ``self._data``; [] when no sole is in contact.

        The corners are :func:`wbc.geometry.projected_sole_corners` (``C Rᵀ + p``): the two uncut soles' in one
        matrix product ``C [R_leftᵀ R_rightᵀ]``, which gives each element the same sum as the product per sole."""
        r = self.robot
        views, cuts = self._sole_views, self._cut
        sides = [s for s in ("left", "right") if self.switcher.in_contact(s)]
        if not sides:
            return []
        plain = [views[s] for s in sides if cuts[s] is None]
        pts: list = []
        if plain:
            corners = self._sole_corners(shrink)
            rt = self._rot_t[len(plain)]
            for j, (_, rot, _) in enumerate(plain):
                rt[:, 3 * j:3 * j + 3] = rot.T
            xy = (corners @ rt).tolist()
            for j, (_, _, pos) in enumerate(plain):
                tx, ty, _ = pos.tolist()
                u = 3 * j
                pts += [(row[u] + tx, row[u + 1] + ty) for row in xy]
        for s in sides:
            cut = cuts[s]
            if cut is None:
                continue
            M = views[s][0]
            a, b = 0.5 * r.sole_length - shrink, 0.5 * r.sole_width - shrink
            x0, x1 = max(-a, cut[0]), min(a, cut[1])
            y0, y1 = max(-b, cut[2]), min(b, cut[3])
            if x1 - x0 < 0.002:  # cut within the margin: a 2 mm strip about its middle (the hull keeps an area)
                x0, x1 = 0.5 * (x0 + x1) - 0.001, 0.5 * (x0 + x1) + 0.001
            if y1 - y0 < 0.002:
                y0, y1 = 0.5 * (y0 + y1) - 0.001, 0.5 * (y0 + y1) + 0.001
            c = np.array([[x1, y1, 0.0], [x0, y1, 0.0], [x0, y0, 0.0], [x1, y0, 0.0]])
            pts += [(x, y) for x, y in (c @ M.rotation.T + M.translation)[:, :2].tolist()]
        vertices = hull_vertices(pts)  # the soles' corners are finite: no validation
        if len(vertices) < 3:
            convex_hull(np.array(pts))  # raises InvalidInputError (collinear)
        return vertices

    def _support(self, shrink: float, px: float, py: float) -> tuple[float, float, float]:
        """(margin, x, y) of the point (px, py) (m, world xy) in :meth:`_hull` ``(shrink)``: its
        :func:`~wbc.geometry.polygon_margin` (m, NaN when no sole is in contact) and the closest point of the hull
        (:func:`closest_point_xy`; the point itself when no sole is in contact). Uncut soles: :func:`support_kernel` on
        the corners of :meth:`_hull`'s matrix product, the same numbers.

        Raises:
            InvalidInputError: the soles' corners are collinear (as :meth:`_hull`).
        """
        views, cuts = self._sole_views, self._cut
        sides = [s for s in ("left", "right") if self.switcher.in_contact(s)]
        if not sides:
            return math.nan, px, py
        if cuts["left"] is not None or cuts["right"] is not None:
            hull = self._hull(shrink)
            return (polygon_margin((px, py), hull),) + closest_point_xy(px, py, hull)
        corners = self._sole_corners(shrink)
        ns = len(sides)
        rt = self._rot_t[ns]
        _, rot, pos0 = views[sides[0]]
        rt[:, :3] = rot.T
        tx1 = ty1 = 0.0
        if ns == 2:
            _, rot, pos1 = views[sides[1]]
            rt[:, 3:] = rot.T
            tx1, ty1 = float(pos1[0]), float(pos1[1])
        m, d, qx, qy = support_kernel(corners @ rt, float(pos0[0]), float(pos0[1]), tx1, ty1, ns, px, py)
        if m < 3:
            self._hull(shrink)  # raises InvalidInputError (collinear)
        return d, qx, qy

    def _stabilize(self, k: int, p_meas: np.ndarray) -> tuple[float, float]:
        """``self.stab.acceleration`` at plan sample ``k`` (no cut sole; measured CoP ``p_meas`` (2,) m, NaN: none), the
        support area that of
        :meth:`_support` ``(cop_margin)``, in one :func:`stabilizer_kernel` call: (c̈_x, c̈_y) m/s², the same numbers
        (the soles' corners from :meth:`_support`'s matrix product).

        Raises:
            InvalidInputError: the soles' corners are collinear (as :meth:`_hull`).
        """
        sw, views, stab = self.switcher, self._sole_views, self.stab
        left, right = sw.in_contact("left"), sw.in_contact("right")
        ns = int(left) + int(right)
        _, rot, pos0 = views["left" if left else "right"]
        pos1 = pos0
        xy = self._xy0
        if ns:
            rt = self._rot_t[ns]
            rt[:, :3] = rot.T
            if ns == 2:
                _, rot, pos1 = views["right"]
                rt[:, 3:] = rot.T
            xy = self._sole_corners(self.cop_margin) @ rt
        args = (xy, ns, pos0, pos1, self._com_view, self._vcom_view, self.ref_dcm[k], self.ref_zmp[k], p_meas,
                stab.law())
        kernel = self._stabilizer_kernel
        if kernel is None:  # its arguments' types are fixed (wbc.compiled.specialise; with kernel type checks on, the
            # dispatcher), but the measured CoP's layout: specialised for any strides
            kernel = self._stabilizer_kernel = stabilizer_kernel if CHECK_TYPES else specialise(
                stabilizer_kernel, *args[:8], np.full(4, np.nan)[::2], args[9])
        m, ax, ay, stab.saturated = kernel(*args)
        if m < 3:
            self._hull(self.cop_margin)  # raises InvalidInputError (collinear)
        return ax, ay


    def _relative_ground(self, k: int, q: np.ndarray) -> None:
        """Touch-down height of a swinging foot relative to the stance sole: its landing height (blind: the
        planned flat ground) plus the stance sole's measured height less its planned one. The estimated base height drifts on terrain (odometry of
        the contact heights, centimetres after ten stairs), the relative height of the two soles (joint encoders)
        does not: an absolute rule loaded a G1 foot 2.4 cm above its tread and the robot fell."""
        sw = self.switcher
        swinging = [s for s in ("left", "right") if sw.phase(s) == "swing"]
        if len(swinging) != 1:
            return
        side = swinging[0]
        other = "right" if side == "left" else "left"
        pin.framesForwardKinematics(self._model, self._gdata, q)
        z_other = float(self._gdata.oMf[self._fid[other]].translation[2])
        self._dz_stance[side] = z_other - float(self.poses[other][k][2, 3])
        sw.ground_height[side] = self._land_z[side] + self._dz_stance[side]

    def _partial_footholds(self, controller, q: np.ndarray, v: np.ndarray, t: float = 0.0) -> None:
        """Blind walk: confine a rolling stance sole's contact to the part of it that is supported (partial
        footholds, Wiedebach, Grabowski, Pratt, "Walking on partial footholds including line contacts with the
        humanoid robot Atlas", Humanoids 2016, Sec. III-B: a foot rotating about an edge has its support polygon cut
        at the line of rotation). On rough ground a sole can rest on one terrain node or edge under it; the QP's
        contact (the whole rectangle) then lets it ask a CoP beyond that edge, which the ground cannot give, and
        the ankle torque rolls the sole over the edge.

        Per side in full contact (``switcher.phase`` "stance") whose measured normal force
        (``measured_normal_force``, N) is at least :data:`BLIND_CUT_LOAD` of the weight: ω (3,) = the sole's
        angular velocity (rad/s, sole axes) from the state (q, v); p = (−τ_y / f_z, τ_x / f_z) the sole's measured
        CoP (m, sole frame) from its F/T ground reaction (``measured_wrench``, sole axes). |ω_y| >
        :data:`BLIND_ROLL_RATE` (pitching): the contact's x range becomes [p_x − h, p_x + h]; |ω_x| > rate (rolling):
        its y range [p_y − h, p_y + h]; h = :data:`BLIND_CUT_BAND` — a line contact through the pivot (the measured
        CoP of a sole rotating about a line of support lies on that line), an edge of the sole included (a sole
        landed on its edge and turning flat about it; :data:`~wbc.gait.blind.BLIND_PIVOT_SLACK`). A band lasts
        while the rotation does and :data:`BLIND_CUT_HOLD` s after, at most until the sole leaves full contact. It
        bounds the QP's corner forces (:meth:`wbc.constraints.sole_contact.SoleContact.set_support`, clipped to the
        sole, at least :data:`BLIND_CUT_MIN` wide) and the stabilizer's support area (:meth:`_hull`).
        Nothing happens without measured wrenches (ground-truth state)."""
        contacts = getattr(controller, "contacts", None)
        f, W = self.measured_normal_force, self.measured_wrench
        A, B = 0.5 * self.robot.sole_length, 0.5 * self.robot.sole_width
        kinematics = False  # forward kinematics with velocities, once per call, only when a sole needs it
        for j, s in enumerate(("left", "right")):
            con = None if contacts is None else contacts.get(s)
            if con is None:
                continue
            cut = list(self._cut[s]) if self._cut[s] is not None else [-np.inf, np.inf, -np.inf, np.inf]
            until = self._cut_until[s]
            new = list(cut)
            if self.switcher.phase(s) != "stance":
                new = [-np.inf, np.inf, -np.inf, np.inf]
            else:
                for ax in (0, 1):  # expired cuts
                    if until[ax] < t:
                        new[2 * ax], new[2 * ax + 1] = -np.inf, np.inf
                fz = 0.0 if W is None else float(W[j][2])
                if f is not None and float(f[j]) >= BLIND_CUT_LOAD * self._weight and fz > 0.0:
                    if not kinematics:
                        pin.forwardKinematics(self._model, self._gdata, q, v)
                        kinematics = True
                    w = pin.getFrameVelocity(self._model, self._gdata, self._fid[s], pin.LOCAL).angular
                    roll_band(new, until, t, w, (-float(W[j][4]) / fz, float(W[j][3]) / fz), (A, B))
            if new == cut:
                continue
            if all(math.isinf(x) for x in new):
                self._cut[s] = None
                con.reset_support()
                continue
            x1, y1 = con.half_size
            x0, y0 = -x1, -y1
            lo_x, hi_x = clip_band_range(max(x0, new[0]), min(x1, new[1]), x0, x1)
            lo_y, hi_y = clip_band_range(max(y0, new[2]), min(y1, new[3]), y0, y1)
            self._cut[s] = tuple(new)
            con.set_support(lo_x, hi_x, lo_y, hi_y)
            self.support_cuts += 1

    def _support_offset(self, k: int) -> tuple[float, float]:
        """Blind walk and planned terrain: height (m) and rate (m/s) added to the planned CoM height at plan sample
        ``k``: the measured − planned height of the soles in contact, weighted by their measured normal forces (``measured_normal_force``;
        equal weights without it), low-passed with the time constant :data:`BLIND_SUPPORT_TAU`. Uses the sole
        placements of the state given to :meth:`update` (``self._data``, updated before the call).

        The CoM then keeps its planned height above the soles, as the swing sole aims at the stance sole's measured
        height (:meth:`_relative_ground`): on uneven ground the estimated base height is contact odometry (each
        sole anchored where it first touches; a sole that then rolls onto the terrain under it moves its anchor point
        with it), so the soles' estimated heights drift, and a CoM held at the planned absolute height bends the
        legs by that drift. On planned terrain the same holds after a flight of stairs: the estimated base height
        drifts by centimetres, the CoM sits that much lower above its stance sole in the plant, and the pelvis rolls
        further with each step down (benchmarks/README.md, "Walking on terrain")."""
        f = self.measured_normal_force
        num = den = 0.0
        for j, s in enumerate(("left", "right")):
            if not self.switcher.in_contact(s):
                continue
            w = 1.0 if f is None else max(float(f[j]), 0.0)
            num += w * (float(self._data.oMf[self._fid[s]].translation[2]) - float(self.poses[s][k][2, 3]))
            den += w
        if den > 0:
            a = self.dt / (self.dt + BLIND_SUPPORT_TAU)
            err = num / den - self._dz_support
            self._dz_support += a * err
            self._dz_support_rate = (1.0 - a) * err / BLIND_SUPPORT_TAU  # d/dt of the low-passed value
        return self._dz_support, self._dz_support_rate

    def _swing_offset(self, side: str, k: int, k_lift: int, k_td: int) -> float:
        """Height (m) added to the planned swing sole at plan sample ``k``: the measured − planned height of the
        swing sole at its release blended (minimum jerk over the swing) into that of the stance sole, so that the
        foot lands on its tread where the touch-down test expects it (:meth:`_relative_ground`). Otherwise a
        foot planned onto the tread's height in the estimate's frame, whose height drifts with the contact
        odometry, stops above or presses into the tread and touch-down comes late or early."""
        b = min_jerk(min(max((k - k_lift) / max(k_td - k_lift, 1), 0.0), 1.0))[0]
        return self._dz_lift[side] + b * (self._dz_stance[side] - self._dz_lift[side])
