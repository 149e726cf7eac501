"""Walk plans: footsteps + support schedule + LIPM CoM + swing feet, precomputed on the control-sample grid.

:func:`plan_walk` returns a :class:`WalkPlan` whose arrays are indexed by the control tick (``dt``, 2 ms by
default), so a 500 Hz controller only reads row ``k`` each tick. :meth:`WalkPlan.replan` re-solves the CoM from
a measured CoM state mid-walk while keeping the remaining footsteps.

Frames and units: world frame, z up, flat ground z = 0; metres, seconds, radians. Sole velocities are those of
the sole-frame origin, linear then angular, both expressed in world axes (Pinocchio's LOCAL_WORLD_ALIGNED).
The CoM math is documented in :mod:`wbc.gait.com_plan`, the footstep convention in :mod:`wbc.gait.footsteps`,
the timing and ZMP reference in :mod:`wbc.gait.schedule`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from wbc.constants import GRAVITY
from wbc.exceptions import GaitError
from wbc.gait.com_plan import lipm_omega, plan_lipm
from wbc.gait.footsteps import Footstep, Side, feet_overlap, plan_footsteps, pose_to_xy_yaw
from wbc.gait.schedule import (
    DOUBLE_SUPPORT,
    LEFT_SUPPORT,
    Phase,
    ZmpSegments,
    build_phases,
    zmp_segments,
)
from wbc.geometry import check_vector, signed_distance, signed_distance_point, support_corners
from wbc.gait.swing import sample_feet
from wbc.profiles import min_jerk, ramped_trapezoid

__all__ = ["WalkPlan", "plan_walk"]

_FLAT_Z_TOL = 0.01  # m: soles must be this close to the ground plane
_FLAT_TILT_TOL = 0.1  # rad: and this close to horizontal
MAX_STRETCH = 250  # samples: the longest lengthening of a single support by replan(skip < 0)


@dataclass(frozen=True, eq=False)
class WalkPlan:
    """A walk sampled every ``dt``; N samples, row k at time ``t[k] = k * dt`` (plan clock).

    All arrays are read-only. Support codes: 0 double support, 1 left stance (right foot swinging), 2 right
    stance (left foot swinging); at a lift-off sample the code is already single support, at a touch-down
    sample it is double support.

    Attributes:
        t: (N,) time (s), ``t[0] = 0``. ``t_offset`` is the time of sample 0 on the clock of the original plan
            (0 for :func:`plan_walk`, ``k * dt`` accumulated by :meth:`replan`).
        com, com_vel, com_acc: (N, 3) CoM position (m), velocity (m/s), acceleration (m/s²), world; z is the
            constant ``com_height`` (z velocity and acceleration are 0).
        zmp: (N, 2) ZMP reference (m), world xy; equals ``com[:, :2] - com_acc[:, :2] / omega**2``.
        dcm: (N, 2) divergent component of motion ``c + ċ/ω`` (m).
            ``com`` .. ``dcm`` are column views of one (N, 13) buffer: each row ``com[k]`` is contiguous.
        left_sole, right_sole: (N, 4, 4) world poses of the sole frames.
        left_sole_vel, right_sole_vel: (N, 6) sole-origin velocity, linear (m/s) then angular (rad/s), world axes.
        support: (N,) int8 support code.
        footsteps: landing poses of the steps not yet completed at sample 0, in order.
        phases: support phases covering samples 0 .. N-1 (sample indices of this plan).
        planned_distance: distance (m) between the feet mid-point (xy) at the first and last sample; for a fresh
            straight walk ``(n_steps - 1) * step_length``.
        duration: ``t[-1]`` (s).
        dt: sample period (s); omega: LIPM frequency (1/s); com_height: CoM height (m);
        sole_length, sole_width: sole rectangle (m), centred on the sole frame.
        segments: the ZMP reference as linear segments on this plan's samples (:class:`ZmpSegments`);
            ``segments.start[0]`` is the start point solved from the initial CoM state. Used by :meth:`replan`.
    """

    t: np.ndarray
    com: np.ndarray
    com_vel: np.ndarray
    com_acc: np.ndarray
    zmp: np.ndarray
    dcm: np.ndarray
    left_sole: np.ndarray
    right_sole: np.ndarray
    left_sole_vel: np.ndarray
    right_sole_vel: np.ndarray
    support: np.ndarray
    footsteps: tuple[Footstep, ...]
    phases: tuple[Phase, ...]
    planned_distance: float
    duration: float
    dt: float
    omega: float
    com_height: float
    sole_length: float
    sole_width: float
    t_offset: float = 0.0
    segments: ZmpSegments | None = field(default=None, repr=False)

    @property
    def n_samples(self) -> int:
        """Number of samples N."""
        return self.t.shape[0]

    def index(self, t: float) -> int:
        """Sample index nearest to time ``t`` (s, plan clock), clamped to ``[0, N-1]``.

        Raises:
            GaitError: ``t`` is not a finite number.
        """
        tf = _scalar(t, "index(t): the time t (s)")
        return int(min(max(round(tf / self.dt), 0), self.n_samples - 1))

    def support_polygon_at(self, k: int) -> np.ndarray:
        """(m, 2) support polygon (CCW, world xy, m) at sample ``k``: the stance sole rectangle in single
        support, the convex hull of both sole rectangles in double support.

        Raises:
            GaitError: ``k`` outside ``[0, N-1]``.
        """
        k = self._check_k(k, self.n_samples - 1)
        return np.array(_support_corners(self.left_sole[k], self.right_sole[k], int(self.support[k]),
                                         self.sole_length, self.sole_width))

    def zmp_margin(self) -> np.ndarray:
        """(N,) signed distance (m, positive inside) of the plan's ZMP to the support polygon at each sample.

        The ZMP is recomputed from the CoM trajectory, ``p = c_xy − c̈_xy / ω²`` (LIPM), not copied from the
        reference; polygons are those of :meth:`support_polygon`, constant over each phase.
        """
        p = self.com[:, :2] - self.com_acc[:, :2] / self.omega**2
        out = np.empty(self.n_samples)
        bounds = [(ph.first, ph.end) for ph in self.phases]
        bounds[-1] = (bounds[-1][0], self.n_samples)
        for (k0, k1) in bounds:
            out[k0:k1] = signed_distance(p[k0:k1], self.support_polygon_at(k0))
        return out

    def replan(self, k: int, com: np.ndarray, com_vel: np.ndarray,
               footsteps: tuple[Footstep, ...] | list[Footstep] | None = None, *,
               check_start: bool = True, skip: int = 0, swing_ramp: float | None = None) -> WalkPlan:
        """Re-plan the CoM from a measured state at sample ``k``, keeping the remaining footsteps and timing.

        The new plan's sample 0 is this plan's sample ``k`` (time re-origined at 0; ``t_offset`` grows by
        ``k * dt``); its feet, support codes and footsteps are this plan's from sample ``k`` on. The ZMP
        reference is unchanged except on the remainder of the current ZMP segment, which becomes linear from a
        solved start point to the segment's original end point, so that the DCM starts at
        ``com + com_vel / ω`` exactly (see :mod:`wbc.gait.com_plan`). Only the xy components of ``com`` and
        ``com_vel`` are used (the plan keeps its CoM height).

        Args:
            k: sample index, ``0 <= k <= N - 2``.
            com: (3,) measured CoM position (m), world.
            com_vel: (3,) measured CoM velocity (m/s), world.
            footsteps: optional new landing poses of the remaining steps (same number, sides and yaws as
                ``footsteps`` of this plan from sample ``k`` on, i.e. of the steps not completed at ``k``; only
                x, y may change — step adjustment, :mod:`wbc.gait.step_adjustment`). The ZMP reference is
                rebuilt from them (:func:`wbc.gait.schedule.zmp_segments`) and every foot trajectory is
                shifted: a foot at rest by the shift of the footstep it stands on, a swing by
                ``d_0 + (d_1 − d_0) b(s)`` with ``d_0``/``d_1`` the shifts of its start/landing footsteps and
                ``b`` the minimum-jerk blend of :mod:`wbc.gait.swing` over the swing (for the swing in progress at
                ``k``: over its remaining samples, so position, velocity and acceleration stay continuous; with
                ``swing_ramp``, that blend is the ramped trapezoid of :mod:`wbc.profiles` instead).
            check_start: raise when the solved ZMP start point is outside the current support polygon (default);
                ``False`` returns the plan anyway (a stabilizer then saturates the CoP at the polygon edge).
            skip: step timing adjustment (Khadiv et al. 2016): end the single support in progress at ``k`` this
                many samples earlier (``-MAX_STRETCH <= skip <=`` its remaining samples − 10, at least 10 samples
                left). The rest of the swing in progress is time-compressed (positions resampled linearly,
                velocities scaled by the compression ratio); everything after it moves ``skip`` samples earlier,
                and the plan is ``skip`` samples shorter. A negative ``skip`` lengthens the single support the same
                way (the swing stretched, the stance foot held, everything after it later; Khadiv et al. 2020's
                step time ``T`` in ``[T_min, T_max]``).
            swing_ramp: None (default): the swing in progress moves by the minimum-jerk blend, whose peak velocity
                is 1.875 times its average; a fraction r, 0 < r ≤ 0.5: by :func:`wbc.profiles.ramped_trapezoid`
                (peak 1/(1 − r) times the average): a late move of the landing then asks the swing leg a lower top
                speed (:attr:`wbc.sim.walk_steps.WalkSteps.swing_ramp`).

        Raises:
            GaitError: bad ``k``, shapes or non-finite values; bad ``footsteps`` (count, side, yaw) or ``k`` in
                the final double support when ``footsteps`` is given; or (``check_start``) the CoM state cannot be
                captured: the ZMP start point needed lies outside the current support polygon (the DCM error is
                too large for the time left in the current ZMP segment — a step would have to change).
        """
        k = self._check_k(k, self.n_samples - 2)
        c = check_vector(com, 3, "com", GaitError)
        cd = check_vector(com_vel, 3, "com_vel", GaitError)
        seg = self.segments
        j = int(np.searchsorted(seg.first, k, side="right")) - 1
        first = seg.first[j:] - k
        count = seg.count[j:].copy()
        count[0] -= k - seg.first[j]
        first[0] = 0
        start = seg.start[j:].copy()
        start[0] = np.nan
        new_seg = ZmpSegments(first, count, start, seg.end[j:], seg.phase[j:] - seg.phase[j])
        ip = int(seg.phase[j])
        phases = [Phase(ph.support, max(ph.first - k, 0), ph.end - max(ph.first, k), ph.step, ph.dt)
                  for ph in self.phases[ip:]]
        n_done = len(self.footsteps) - sum(1 for ph in phases if ph.support != DOUBLE_SUPPORT)
        phases = [Phase(ph.support, ph.first, ph.count, ph.step - n_done if ph.step >= 0 else -1, ph.dt)
                  for ph in phases]
        steps = self.footsteps[n_done:]
        feet = (self.left_sole[k:], self.right_sole[k:], self.left_sole_vel[k:], self.right_sole_vel[k:])
        support = self.support[k:]
        if swing_ramp is not None and (isinstance(swing_ramp, bool) or not isinstance(swing_ramp, (int, float))
                                       or not 0.0 < swing_ramp <= 0.5):
            raise GaitError(f"swing_ramp must be None or a number in (0, 0.5]; got {swing_ramp!r}")
        skip = int(skip)
        if skip:
            if phases[0].support == DOUBLE_SUPPORT or not (-MAX_STRETCH <= skip <= phases[0].count - 10) \
                    or phases[0].count < 10:
                raise GaitError(f"skip must be in [-{MAX_STRETCH}, remaining single-support samples - 10] with >= 10 "
                                f"samples left; got {skip} (phase at k: support {phases[0].support}, "
                                f"{phases[0].count} samples left)")
        if footsteps is not None:
            new_steps = _check_new_footsteps(footsteps, steps)
            if phases[-1] is phases[0] or len(seg.first) - j != len(phases) + 1:
                raise GaitError("cannot change footsteps in the final double support (no step left)")
            pts = zmp_segments(phases, list(new_steps), tuple(feet[0][0, :2, 3]), tuple(feet[1][0, :2, 3]),
                               int(seg.count[-2]))
            start = pts.start.astype(float).copy()
            start[0] = np.nan
            new_seg = ZmpSegments(first, count, start, pts.end.astype(float), new_seg.phase)
            feet = _shift_feet(feet, phases, steps, new_steps, swing_ramp)
            steps = new_steps
        if skip:
            n0 = phases[0].count
            f = 0 if steps[phases[0].step].side == "left" else 1
            feet = _compress_swing(feet, f, n0, skip)
            support = np.concatenate([support[:n0 - skip], support[n0:]]) if skip > 0 else \
                np.concatenate([support[:n0], np.repeat(support[n0 - 1:n0], -skip), support[n0:]])
            support.flags.writeable = False
            phases = [Phase(phases[0].support, 0, n0 - skip, phases[0].step, phases[0].dt)] + [
                Phase(ph.support, ph.first - skip, ph.count, ph.step, ph.dt) for ph in phases[1:]]
            cnt = new_seg.count.copy()
            fst = new_seg.first.copy()
            cnt[0] -= skip
            fst[1:] -= skip
            new_seg = ZmpSegments(fst, cnt, new_seg.start, new_seg.end, new_seg.phase)
        return _assemble(
            new_seg, phases, steps, c[:2], cd[:2], self.com_height, self.omega, self.dt, feet, support,
            length=self.sole_length, width=self.sole_width, t_offset=self.t_offset + k * self.dt,
            check_start=check_start,
        )

    def _check_k(self, k: int, k_max: int) -> int:
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k <= k_max:
            raise GaitError(f"sample index must be an integer in [0, {k_max}]; got {k!r}")
        return int(k)


def _support_corners(left: np.ndarray, right: np.ndarray, support: int, length: float,
                     width: float) -> list[tuple[float, float]]:
    """Support polygon (CCW vertex list, :func:`wbc.geometry.support_corners`) for the given sole poses and support
    code."""
    if support == DOUBLE_SUPPORT:
        return support_corners((pose_to_xy_yaw(left), pose_to_xy_yaw(right)), length, width)
    return support_corners((pose_to_xy_yaw(left if support == LEFT_SUPPORT else right),), length, width)


def _readonly(*arrays: np.ndarray) -> None:
    for a in arrays:
        a.flags.writeable = False


def _assemble(seg: ZmpSegments, phases: list[Phase], footsteps: tuple[Footstep, ...] | list[Footstep],
              com_xy: np.ndarray, com_vel_xy: np.ndarray, com_height: float, omega: float, dt: float,
              feet: tuple, support: np.ndarray, *, length: float, width: float, t_offset: float,
              check_start: bool = True) -> WalkPlan:
    """Solve the CoM for ``seg`` from the given state, check the solved ZMP start point, build the plan. ``feet``:
    the soles' samples (left, right, left_vel, right_vel); ``length``, ``width``: the sole (m); ``t_offset``: the
    plan's start time (s)."""
    left, right, left_vel, right_vel = feet
    lipm = plan_lipm(seg.first, seg.count, seg.start, seg.end, com_xy, com_vel_xy, omega, dt)
    a0 = lipm.start[0]
    ax, ay = float(a0[0]), float(a0[1])
    poly = _support_corners(left[0], right[0], int(support[0]), length, width)
    margin = signed_distance_point(ax, ay, poly) if math.isfinite(ax) and math.isfinite(ay) else -math.inf
    if check_start and not margin >= -1e-9:
        raise GaitError(
            f"cannot start the walk from CoM {np.round(com_xy, 4).tolist()} m with velocity "
            f"{np.round(com_vel_xy, 4).tolist()} m/s: the ZMP would have to start at {np.round(a0, 4).tolist()} m, "
            f"{-margin:.4f} m outside the current support polygon; the DCM c + v/ω must be steerable with the ZMP "
            f"inside the support polygon within the time left in the current ZMP segment ({seg.count[0] * dt:.3f} s)"
        )
    seg = ZmpSegments(seg.first, seg.count, lipm.start, seg.end, seg.phase)
    smp = lipm.sample(com_height)
    com, com_vel, com_acc = smp.com, smp.com_vel, smp.com_acc
    n = com.shape[0]
    t = np.arange(n) * dt
    mid0 = 0.5 * (left[0, :2, 3] + right[0, :2, 3])
    mid1 = 0.5 * (left[-1, :2, 3] + right[-1, :2, 3])
    _readonly(t, com, com_vel, com_acc, smp.zmp, smp.dcm, seg.first, seg.count, seg.start, seg.end, seg.phase)
    return WalkPlan(
        t=t, com=com, com_vel=com_vel, com_acc=com_acc, zmp=smp.zmp, dcm=smp.dcm,
        left_sole=left, right_sole=right, left_sole_vel=left_vel, right_sole_vel=right_vel, support=support,
        footsteps=tuple(footsteps), phases=tuple(phases), planned_distance=float(np.linalg.norm(mid1 - mid0)),
        duration=float(t[-1]), dt=dt, omega=omega, com_height=com_height, sole_length=length, sole_width=width,
        t_offset=t_offset, segments=seg,
    )


def _check_new_footsteps(new, old: tuple[Footstep, ...]) -> tuple[Footstep, ...]:
    """Validate replacement footsteps: same count, sides and yaws as ``old``, finite x, y."""
    new = tuple(new)
    if len(new) != len(old):
        raise GaitError(f"footsteps: expected {len(old)} remaining steps, got {len(new)}")
    out = []
    for i, (a, b) in enumerate(zip(new, old)):
        if not isinstance(a, Footstep):
            raise GaitError(f"footsteps[{i}] must be a Footstep; got {type(a).__name__}")
        if a.side != b.side or abs(a.yaw - b.yaw) > 1e-12:
            raise GaitError(f"footsteps[{i}]: only x, y may change (side {b.side}, yaw {b.yaw:.6f} rad); "
                            f"got side {a.side}, yaw {a.yaw:.6f} rad")
        if not (math.isfinite(a.x) and math.isfinite(a.y)):
            raise GaitError(f"footsteps[{i}] must have finite x, y; got ({a.x}, {a.y})")
        out.append(a)
    return tuple(out)


def _shift_feet(feet, phases: list[Phase], old: tuple[Footstep, ...], new: tuple[Footstep, ...],
                ramp: float | None = None):
    """Foot trajectories (left, right poses (N, 4, 4), velocities (N, 6)) shifted for moved footsteps (see
    :meth:`WalkPlan.replan`): rest by the shift of the footstep stood on, swings by ``d0 + (d1 − d0) b(s)``, ``b``
    the minimum-jerk blend, or for the swing in progress (``phases[0]``) with a ``ramp``, the ramped trapezoid."""
    poses = [feet[0].copy(), feet[1].copy()]
    vels = [feet[2].copy(), feet[3].copy()]
    dt = phases[0].dt
    shift = [np.zeros(2), np.zeros(2)]  # current shift of each foot's rest pose
    for ph in phases:
        if ph.support == DOUBLE_SUPPORT or ph.step < 0:
            continue
        f = 0 if old[ph.step].side == "left" else 1
        d0 = shift[f]
        d1 = np.array([new[ph.step].x - old[ph.step].x, new[ph.step].y - old[ph.step].y])
        n = ph.count
        s = np.arange(n) / n
        b, db, _ = ramped_trapezoid(s, ramp) if ramp is not None and ph is phases[0] else min_jerk(s)
        # Samples from this swing on already carry d0 (added with the previous swing's landing).
        poses[f][ph.first:ph.first + n, :2, 3] += np.outer(b, d1 - d0)
        vels[f][ph.first:ph.first + n, :2] += np.outer(db / (n * dt), d1 - d0)
        poses[f][ph.first + n:, :2, 3] += d1 - d0
        shift[f] = d1
    for a in (*poses, *vels):
        a.flags.writeable = False
    return poses[0], poses[1], vels[0], vels[1]


def _compress_swing(feet, f: int, n0: int, skip: int):
    """Feet arrays with the first ``n0`` samples of foot ``f`` (its swing in progress; sample ``n0`` is its landing)
    resampled onto ``n0 − skip`` samples, and ``skip`` samples of the other foot's rest dropped (``skip < 0``:
    ``−skip`` samples of its rest repeated)."""
    poses = [np.asarray(feet[0]), np.asarray(feet[1])]
    vels = [np.asarray(feet[2]), np.asarray(feet[3])]
    m = n0 - skip
    x = np.arange(m) * (n0 / m)
    i0 = np.floor(x).astype(int)
    a = (x - i0)[:, None]
    i1 = np.minimum(i0 + 1, n0)
    out_p, out_v = [], []
    for g in range(2):
        P, V = poses[g], vels[g]
        if g == f:
            head = P[np.rint(x).astype(int)].copy()  # rotations: nearest sample
            head[:, :3, 3] = (1 - a) * P[i0, :3, 3] + a * P[i1, :3, 3]
            vhead = ((1 - a) * V[i0] + a * V[i1]) * (n0 / m)
            out_p.append(np.concatenate([head, P[n0:]]))
            out_v.append(np.concatenate([vhead, V[n0:]]))
        elif skip >= 0:
            out_p.append(np.concatenate([P[:m], P[n0:]]))
            out_v.append(np.concatenate([V[:m], V[n0:]]))
        else:  # stretched: the other foot (at rest in this single support) held for -skip more samples
            out_p.append(np.concatenate([P[:n0], np.repeat(P[n0 - 1:n0], -skip, axis=0), P[n0:]]))
            out_v.append(np.concatenate([V[:n0], np.repeat(V[n0 - 1:n0], -skip, axis=0), V[n0:]]))
    for arr in (*out_p, *out_v):
        arr.flags.writeable = False
    return out_p[0], out_p[1], out_v[0], out_v[1]


def _sole_pose(x, name: str) -> np.ndarray:
    if isinstance(x, pin.SE3):
        x = x.homogeneous
    try:
        m = np.array(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise GaitError(f"{name} must be a pin.SE3 or a (4, 4) homogeneous matrix; got {type(x).__name__}") from exc
    if m.shape != (4, 4):
        raise GaitError(f"{name} must be a pin.SE3 or a (4, 4) homogeneous matrix; got shape {m.shape}")
    rows = m.tolist()
    if not all(math.isfinite(v) for row in rows for v in row):
        raise GaitError(f"{name} must be finite; got NaN or inf")
    r = [row[:3] for row in rows[:3]]
    cols = list(zip(*r))
    ortho = max(abs(sum(a * b for a, b in zip(cols[i], cols[j])) - (i == j)) for i in range(3) for j in range(3))
    x_axis, y_axis, z_axis = cols
    det = sum(p * q for p, q in zip(z_axis, (x_axis[1] * y_axis[2] - x_axis[2] * y_axis[1],
                                              x_axis[2] * y_axis[0] - x_axis[0] * y_axis[2],
                                              x_axis[0] * y_axis[1] - x_axis[1] * y_axis[0])))
    if ortho > 1e-6 or det < 0 or rows[3] != [0.0, 0.0, 0.0, 1.0]:
        raise GaitError(f"{name} must be a rigid transform (orthonormal rotation, last row [0, 0, 0, 1])")
    if abs(rows[2][3]) > _FLAT_Z_TOL or r[2][2] < math.cos(_FLAT_TILT_TOL):
        raise GaitError(
            f"{name} must lie flat on the ground z = 0 (|z| <= {_FLAT_Z_TOL} m, tilt <= {_FLAT_TILT_TOL} rad); "
            f"got z = {rows[2][3]:.4f} m, tilt = {math.acos(max(-1.0, min(1.0, r[2][2]))):.4f} rad"
        )
    return m


def _scalar(x, name: str, *, positive: bool = False, nonneg: bool = False) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError) as exc:
        raise GaitError(f"{name} must be a finite number; got {x!r}") from exc
    if not math.isfinite(v):
        raise GaitError(f"{name} must be a finite number; got {x!r}")
    if positive and not v > 0:
        raise GaitError(f"{name} must be > 0; got {v}")
    if nonneg and not v >= 0:
        raise GaitError(f"{name} must be >= 0; got {v}")
    return v


def _durations(t, name: str, n_steps: int, dt: float):
    """Samples of a duration ``t`` (s, > 0), or a list of them for a sequence of ``n_steps`` durations."""
    if isinstance(t, (list, tuple, np.ndarray)):
        if len(t) != n_steps:
            raise GaitError(f"{name} must be one duration (s) or a sequence of n_steps = {n_steps} durations; got "
                            f"{len(t)} durations")
        return [_samples(_scalar(x, f"{name}[{i}]", positive=True), dt, f"{name}[{i}]") for i, x in enumerate(t)]
    return _samples(_scalar(t, name, positive=True), dt, name)


def _samples(duration: float, dt: float, name: str, minimum: int = 1) -> int:
    n = round(duration / dt)
    if n < minimum:
        raise GaitError(f"{name} = {duration} s is shorter than {minimum} sample(s) of dt = {dt} s")
    return n


def plan_walk(
    left_sole: np.ndarray | pin.SE3,
    right_sole: np.ndarray | pin.SE3,
    com: np.ndarray,
    *,
    n_steps: int = 8,
    step_length: float = 0.15,
    step_width: float | None = None,
    turn: float = 0.0,
    step_height: float = 0.05,
    t_ss: float | list[float] | tuple[float, ...] = 0.8,
    t_ds: float | list[float] | tuple[float, ...] = 0.3,
    t_init: float = 1.0,
    t_final: float = 1.2,
    dt: float = 0.002,
    sole_length: float = 0.21,
    sole_width: float = 0.13,
    com_velocity: np.ndarray | None = None,
    first_side: Side = "left",
    gravity: float = GRAVITY,
    step_lateral: float = 0.0,
    check_start: bool = True,
) -> WalkPlan:
    """Plan a walk from the current feet and CoM: footsteps, schedule, LIPM CoM and swing-foot trajectories.

    Footstep convention: :mod:`wbc.gait.footsteps` (steps 1..n-1 advance ``step_length`` ahead of the stance
    foot, step n closes alongside). Timing and ZMP reference: :mod:`wbc.gait.schedule` (durations rounded to
    whole samples). CoM: exact LIPM/DCM solution of :mod:`wbc.gait.com_plan` (Englsberger, Ott, Albu-Schäffer,
    IEEE T-RO 31(2), 2015), starting exactly at ``com`` / ``com_velocity`` and ending at rest over the final
    feet mid-point. Swing: :mod:`wbc.gait.swing` (minimum-jerk, clearance bump ``step_height``).

    Args:
        left_sole, right_sole: current world poses of the sole frames, (4, 4) or ``pin.SE3``, flat on z = 0
            (|z| <= 1 cm, tilt <= 0.1 rad); the left sole must be on the left of the right one.
        com: (3,) current CoM (m), world; ``com[2] > 0`` is the constant CoM height of the plan.
        n_steps: number of swing phases, integer >= 1.
        step_length: forward displacement (m) of each walking step relative to the stance foot.
        step_width: lateral distance (m) between the feet; default: the current one.
        turn: yaw change (rad) per walking step, ``|turn| < pi/2``; positive turns left.
        step_height: swing clearance (m, >= 0).
        t_ss, t_ds: single / double support durations (s, > 0); either may also be a sequence of ``n_steps``
            durations, one per step (the swing of step i lasts ``t_ss[i]``, the double support after it ``t_ds[i]``,
            the last one unused; step timing on terrain, :func:`wbc.gait.terrain_walk.plan_terrain_walk`).
        t_init: initial double support (s, > 0): the CoM shifts towards the first stance foot.
        t_final: final double support (s, >= 2 dt): ZMP back to the feet mid-point, CoM settles.
        dt: sample period (s, > 0).
        sole_length, sole_width: sole rectangle (m, > 0), centred on the sole frame, x forward.
        com_velocity: (3,) current CoM velocity (m/s); default 0. Only xy is used.
        first_side: the foot that swings first, ``"left"`` or ``"right"``.
        gravity: gravity acceleration (m/s², > 0).
        step_lateral: lateral displacement (m, + left) of the feet mid-point per walking step (side-stepping,
            :mod:`wbc.gait.footsteps`).
        check_start: raise when the CoM state cannot be captured (below); ``False`` returns the plan with its solved
            ZMP start point wherever it is (e.g. as the nominal geometry of a capture step, then replanned).

    Returns:
        A :class:`WalkPlan` sampled at ``dt``.

    Raises:
        GaitError: invalid argument (the message names it and the valid range), feet overlapping at the start
            or at a footstep, or a CoM state that cannot be captured from the current support polygon.
    """
    L = _sole_pose(left_sole, "left_sole")
    R = _sole_pose(right_sole, "right_sole")
    c = check_vector(com, 3, "com", GaitError)
    if not c[2] > 0:
        raise GaitError(f"com height com[2] must be > 0 m above the ground; got {c[2]}")
    cd = np.zeros(3) if com_velocity is None else check_vector(com_velocity, 3, "com_velocity", GaitError)
    if isinstance(n_steps, bool) or not isinstance(n_steps, (int, np.integer)) or n_steps < 1:
        raise GaitError(f"n_steps must be an integer >= 1; got {n_steps!r}")
    if first_side not in ("left", "right"):
        raise GaitError(f"first_side must be 'left' or 'right'; got {first_side!r}")
    dt = _scalar(dt, "dt", positive=True)
    step_length = _scalar(step_length, "step_length")
    turn = _scalar(turn, "turn")
    if not abs(turn) < math.pi / 2:
        raise GaitError(f"turn must be in (-pi/2, pi/2) rad per step; got {turn}")
    step_height = _scalar(step_height, "step_height", nonneg=True)
    length = _scalar(sole_length, "sole_length", positive=True)
    width = _scalar(sole_width, "sole_width", positive=True)
    g = _scalar(gravity, "gravity", positive=True)
    n_init = _samples(_scalar(t_init, "t_init", positive=True), dt, "t_init")
    n_ss = _durations(t_ss, "t_ss", int(n_steps), dt)
    n_ds = _durations(t_ds, "t_ds", int(n_steps), dt)
    n_final = _samples(_scalar(t_final, "t_final", positive=True), dt, "t_final", minimum=2)

    lft, rgt = pose_to_xy_yaw(L), pose_to_xy_yaw(R)
    heading = math.atan2(math.sin(lft[2]) + math.sin(rgt[2]), math.cos(lft[2]) + math.cos(rgt[2]))
    lateral = -(lft[0] - rgt[0]) * math.sin(heading) + (lft[1] - rgt[1]) * math.cos(heading)
    if not lateral > 0:
        raise GaitError(f"left_sole must be on the left of right_sole (lateral offset {lateral:.4f} m <= 0)")
    if step_width is None:
        step_width = lateral
    step_width = _scalar(step_width, "step_width", positive=True)
    step_lateral = _scalar(step_lateral, "step_lateral")
    steps = plan_footsteps(lft, rgt, int(n_steps), step_length, step_width, turn, first_side, step_lateral)

    # Overlap check: initial feet, then each landing pose against its stance foot.
    feet = {"left": lft, "right": rgt}
    pairs_a, pairs_b = [lft], [rgt]
    for fs in steps:
        pairs_a.append(feet["right" if fs.side == "left" else "left"])
        pairs_b.append((fs.x, fs.y, fs.yaw))
        feet[fs.side] = (fs.x, fs.y, fs.yaw)
    hit = feet_overlap(np.array(pairs_a), np.array(pairs_b), length, width)
    if hit.any():
        i = int(np.argmax(hit))
        where = "the initial feet overlap" if i == 0 else f"step {i} lands on the stance foot"
        raise GaitError(f"{where} (soles {length} x {width} m); increase step_width (now {step_width:.4f} m, "
                        f"must exceed the sole width {width} m) or reduce turn (now {turn} rad)")

    phases = build_phases(int(n_steps), first_side, n_init, n_ss, n_ds, n_final, dt)
    n_ramp = n_ds if isinstance(n_ds, int) else n_ds[-1]  # (the last entry follows no step: the nominal one)
    seg = zmp_segments(phases, steps, lft[:2], rgt[:2], max(1, min(n_ramp, n_final // 2)))
    n = phases[-1].end + 1

    swings = [ph for ph in phases if ph.step >= 0]
    foot = [0 if steps[ph.step].side == "left" else 1 for ph in swings]
    poses, vels = sample_feet(n, np.array([L, R]), np.array([steps[ph.step].pose() for ph in swings]), foot,
                              [ph.first for ph in swings], n_ss, dt, step_height)
    lp, rp, lv, rv = poses[0], poses[1], vels[0], vels[1]
    counts = [ph.count for ph in phases]
    counts[-1] += 1  # the last sample closes the final double support
    support = np.repeat(np.array([ph.support for ph in phases], dtype=np.int8), counts)
    _readonly(lp, lv, rp, rv, support)
    return _assemble(seg, phases, steps, c[:2], cd[:2], float(c[2]), lipm_omega(float(c[2]), g), dt,
                     (lp, rp, lv, rv), support, length=length, width=width, t_offset=0.0, check_start=check_start)
