"""The blind walk's swing and foothold laws: testable without a simulator.

A blind walk (:class:`wbc.sim.walk.WalkScenario` with ``blind=True``) plans on flat ground and meets the terrain as
it comes. Two control laws adapt the plan to it:

- :func:`blind_swing_into`: the swing sole reaches its foothold's xy and heading early and descends vertically, its
  clearance a lift held over the swing (an early contact lands where planned, with no horizontal speed).
- :func:`roll_band`, :func:`clip_band_range`: partial footholds (Wiedebach, Grabowski, Pratt, "Walking on partial
  footholds including line contacts with the humanoid robot Atlas", Humanoids 2016, Sec. III-B): a loaded stance
  sole rotating about a line of its sole (an inner line or an edge) has its contact rectangle cut to a band about
  that line through its measured CoP.

Frames and units: world (swing), sole frame (bands); m, s, rad.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.profiles import min_jerk

__all__ = ["BLIND_XY_END", "BLIND_LIFT", "BLIND_SET_DOWN", "BLIND_ROLL_RATE", "BLIND_CUT_BAND", "BLIND_CUT_LOAD",
           "BLIND_CUT_MIN", "BLIND_PIVOT_SLACK", "BLIND_CUT_HOLD", "blind_swing_into", "clip_band_range", "roll_band"]

#: Blind walk: fraction of a swing by which the swing sole has reached its foothold's xy and heading (the rest of the
#: swing descends vertically; :func:`blind_swing_into`).
BLIND_XY_END = 0.8
#: Blind walk: fraction of a swing over which the sole rises to its clearance height (minimum jerk).
BLIND_LIFT = 0.3
#: Blind walk: fraction of a swing from which the sole is set down (minimum jerk to the landing height).
BLIND_SET_DOWN = 0.6
#: Blind walk, partial footholds (:func:`roll_band`): a loaded sole (measured normal force
#: ≥ :data:`BLIND_CUT_LOAD` of the weight) rotating faster than this (rad/s, about a sole axis) has its contact
#: rectangle cut to a band about the line of rotation through its measured CoP.
BLIND_ROLL_RATE = 0.6
#: Blind walk: half width (m) of the band about the measured CoP to which a rolling sole's contact is cut.
BLIND_CUT_BAND = 0.01
#: Blind walk: fraction of the weight a sole must carry for its rolling to cut its contact rectangle.
BLIND_CUT_LOAD = 0.1
#: Blind walk: smallest length and width (m) a cut leaves of a contact rectangle.
BLIND_CUT_MIN = 0.02
#: Blind walk: a rolling sole's pivot (measured CoP) must lie on the sole, at most this far (m) beyond its edges (the
#: F/T CoP of a sole turning about its edge reads a few millimetres past it), for a cut. A pivot on an edge is cut
#: too: a sole landed on its edge and turning flat about it at the QP's CoP rolled its ankle past the joint's speed
#: limit (benchmarks/records/47-*.md).
BLIND_PIVOT_SLACK = 0.01
#: Blind walk: a cut lasts this long (s) after the sole's rolling last exceeded :data:`BLIND_ROLL_RATE`.
BLIND_CUT_HOLD = 0.1


def blind_swing_into(track, k: int, k_lift: int, k_td: int, step_height: float, dt: float, pose: pin.SE3,
                     vel: np.ndarray, acc: np.ndarray) -> None:
    """Blind walk: the planned swing's horizontal motion and rotation run ``1 / BLIND_XY_END`` times faster,
    over the first ``BLIND_XY_END`` of the swing (plan sample ``k`` between lift-off ``k_lift`` and touch-down
    ``k_td``); the sole then descends vertically over its foothold, so a touch-down on ground above the planned
    one (early contact) lands where planned, with no horizontal speed. Its clearance bump is replaced by a lift
    of the same height ``h`` that rises over the first :data:`BLIND_LIFT` of the swing (minimum jerk), is held,
    and is set down from :data:`BLIND_SET_DOWN` on: the toe clears the bumps ahead while the foot has barely
    moved forward (the bump ``h · 64 s³ (1 − s)³`` is at 0.26 h when the foot has covered a tenth of its step,
    and the toe of a sole lifted off rough ground struck the facets ahead). Modifies ``pose``, ``vel`` and
    ``acc`` in place.

    Args:
        track: (poses (N, 4, 4), velocities (N, 6), accelerations (N, 6)) of the swing sole on the flat plan (world;
            linear then angular). step_height: clearance h (m). dt: plan period (s).
    """
    poses, vels, accs = track
    n = max(k_td - k_lift, 1)
    T = n * dt
    s = (k - k_lift) / n
    if s >= BLIND_XY_END:
        kx, r = k_td, 0.0
    else:
        kx, r = k_lift + int(round(s / BLIND_XY_END * n)), 1.0 / BLIND_XY_END
    P = poses[min(kx, k_td)]
    z_bump = float(poses[k][2, 3] - poses[k_td][2, 3])  # the flat plan's bump at k
    up_b, up_d, up_dd = min_jerk(s / BLIND_LIFT)
    dn_b, dn_d, dn_dd = min_jerk((1.0 - s) / (1.0 - BLIND_SET_DOWN))
    a, c, h = BLIND_LIFT, 1.0 - BLIND_SET_DOWN, step_height
    lift = h * up_b * dn_b
    dlift = h * (up_d / a * dn_b - up_b * dn_d / c) / T
    ddlift = h * (up_dd / a**2 * dn_b - 2.0 * up_d * dn_d / (a * c) + up_b * dn_dd / c**2) / T**2
    pose.rotation = P[:3, :3]
    pose.translation = np.array([P[0, 3], P[1, 3], pose.translation[2] - z_bump + lift])
    vx, ax = vels[kx], accs[kx]
    vz, az = float(vels[k][2]), float(accs[k][2])
    vel[:2], vel[3:] = r * vx[:2], r * vx[3:]
    acc[:2], acc[3:] = r * r * ax[:2], r * r * ax[3:]
    vel[2], acc[2] = vel[2] - vz + dlift, acc[2] - az + ddlift


def clip_band_range(lo: float, hi: float, a: float, b: float) -> tuple[float, float]:
    """[lo, hi] widened to :data:`BLIND_CUT_MIN` about its middle and kept inside [a, b] (m)."""
    if hi - lo < BLIND_CUT_MIN:
        m = min(max(0.5 * (lo + hi), a + 0.5 * BLIND_CUT_MIN), b - 0.5 * BLIND_CUT_MIN)
        lo, hi = m - 0.5 * BLIND_CUT_MIN, m + 0.5 * BLIND_CUT_MIN
    return lo, hi


def roll_band(band: list, until: list, t: float, omega, cop, half_size) -> None:
    """Cut a loaded stance sole's contact band about its line of rotation (module docstring), in place.

    |ω_y| > :data:`BLIND_ROLL_RATE` (pitching) with the measured CoP's x on the sole (up to :data:`BLIND_PIVOT_SLACK`
    beyond its edges): band[0:2] = [p_x − h, p_x + h] and until[0] = t + :data:`BLIND_CUT_HOLD`; |ω_x| > rate
    (rolling) likewise for y (band[2:4], until[1]); h = :data:`BLIND_CUT_BAND`.

    Args:
        band: [lo_x, hi_x, lo_y, hi_y] (m, sole frame; ±inf: not cut). until: [x, y] expiry times of the cuts (s).
        t: time (s). omega: (3,) the sole's angular velocity (rad/s, sole axes). cop: (p_x, p_y) the sole's
            measured CoP (m, sole frame). half_size: (A, B) the sole's half length and half width (m).
    """
    A, B = half_size
    px, py = cop
    e = -BLIND_PIVOT_SLACK
    h = BLIND_CUT_BAND
    if abs(omega[1]) > BLIND_ROLL_RATE and -A + e < px < A - e:  # pitching about a line of the sole
        band[0], band[1] = px - h, px + h
        until[0] = t + BLIND_CUT_HOLD
    if abs(omega[0]) > BLIND_ROLL_RATE and -B + e < py < B - e:  # rolling about a line of the sole
        band[2], band[3] = py - h, py + h
        until[1] = t + BLIND_CUT_HOLD
